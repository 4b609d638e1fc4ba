// Generic OpenGL helpers (see gl_helpers.hpp).
#include "gl_helpers.hpp"

#include <algorithm>
#include <cstdio>

namespace horizon::gpu {
namespace {

// `object` when its compile (shader) or link (program) status is good;
// otherwise 0, with its info log in `log` and the object deleted.
GLuint checked(GLuint object, bool program, std::string& log) {
  GLint ok = 0;
  program ? glGetProgramiv(object, GL_LINK_STATUS, &ok) : glGetShaderiv(object, GL_COMPILE_STATUS, &ok);
  if (ok) return object;
  char buffer[4096] = {};
  program ? glGetProgramInfoLog(object, sizeof buffer, nullptr, buffer)
          : glGetShaderInfoLog(object, sizeof buffer, nullptr, buffer);
  log = buffer;
  program ? glDeleteProgram(object) : glDeleteShader(object);
  return 0;
}

std::string gl_error_name(GLenum e) {
  switch (e) {
    case GL_OUT_OF_MEMORY:
      return "GL_OUT_OF_MEMORY";
    case GL_INVALID_OPERATION:
      return "GL_INVALID_OPERATION";
    case GL_INVALID_VALUE:
      return "GL_INVALID_VALUE";
    case GL_INVALID_ENUM:
      return "GL_INVALID_ENUM";
    case GL_INVALID_FRAMEBUFFER_OPERATION:
      return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_CONTEXT_LOST:
      return "GL_CONTEXT_LOST";
    default: {
      char buffer[32];
      std::snprintf(buffer, sizeof buffer, "GL error 0x%04X", e);
      return buffer;
    }
  }
}

}  // namespace

GLuint compile_shader(GLenum type, const std::string& source, std::string& log) {
  GLuint shader = glCreateShader(type);
  const char* text = source.c_str();
  glShaderSource(shader, 1, &text, nullptr);
  glCompileShader(shader);
  return checked(shader, false, log);
}

GLuint link_program(std::initializer_list<GLuint> shaders, std::string& log) {
  GLuint program = glCreateProgram();
  for (GLuint s : shaders) glAttachShader(program, s);
  glLinkProgram(program);
  for (GLuint s : shaders) glDeleteShader(s);
  return checked(program, true, log);
}

std::uint64_t texel_bytes(GLenum internal_format) {
  switch (internal_format) {
    case GL_R8:
    case GL_R8UI:
      return 1;
    case GL_R16F:
    case GL_R16UI:
      return 2;
    case GL_R32F:
    case GL_R32UI:
    case GL_R32I:
    case GL_RGBA8:
      return 4;
    case GL_RG32F:
    case GL_RG32UI:
    case GL_RGBA16F:
      return 8;
    default:
      return 16;
  }
}

Texture2D::~Texture2D() {
  release();
}

void Texture2D::release() {
  if (texture != 0) glDeleteTextures(1, &texture);
  texture = 0;
  width = height = 0;
}

std::uint64_t Texture2D::bytes_after(int w, int h) const {
  const int after_w = std::max(w, width), after_h = std::max(h, height);
  if (after_w == 0 || after_h == 0) return 0;
  return std::uint64_t(after_w) * std::uint64_t(after_h) * texel_bytes(format);
}

void Texture2D::ensure(int w, int h) {
  if (texture != 0 && w <= width && h <= height) return;
  if (texture != 0) glDeleteTextures(1, &texture);
  width = std::max(w, width);
  height = std::max(h, height);
  glGenTextures(1, &texture);
  glBindTexture(GL_TEXTURE_2D, texture);
  glTexStorage2D(GL_TEXTURE_2D, 1, format, width, height);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
}

StorageBuffer::~StorageBuffer() {
  release();
}

void StorageBuffer::release() {
  if (id != 0) glDeleteBuffers(1, &id);
  id = 0;
  capacity = 0;
}

void StorageBuffer::upload(GLuint binding, const void* data, std::size_t bytes) {
  if (id == 0) glGenBuffers(1, &id);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, binding, id);
  if (bytes > capacity) {
    capacity = std::max(bytes, 2 * capacity);
    glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(capacity), nullptr, GL_DYNAMIC_DRAW);
  }
  glBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(bytes), data);
}

void StorageBuffer::reserve(GLuint binding, std::size_t bytes) {
  if (id == 0) glGenBuffers(1, &id);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, binding, id);
  if (bytes > capacity) {
    capacity = std::max(bytes, 2 * capacity);
    glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(capacity), nullptr, GL_DYNAMIC_READ);
  }
}

void StorageBuffer::download(void* data, std::size_t bytes) const {
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, id);
  glGetBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(bytes), data);
}

TextureArray::~TextureArray() {
  release();
}

void TextureArray::release() {
  if (texture != 0) glDeleteTextures(1, &texture);
  texture = 0;
  width = height = layers = 0;
}

std::uint64_t TextureArray::bytes() const {
  return std::uint64_t(width) * std::uint64_t(height) * std::uint64_t(layers) * texel_bytes(format);
}

std::uint64_t TextureArray::bytes_after(int w, int h, int layer_count) const {
  return std::uint64_t(w) * std::uint64_t(h) * std::uint64_t(layer_count) * texel_bytes(format);
}

bool TextureArray::ensure(int w, int h, int layer_count) {
  if (texture != 0 && w == width && h == height && layer_count == layers) return false;
  if (texture != 0) glDeleteTextures(1, &texture);
  width = w;
  height = h;
  layers = layer_count;
  glGenTextures(1, &texture);
  glBindTexture(GL_TEXTURE_2D_ARRAY, texture);
  glTexStorage3D(GL_TEXTURE_2D_ARRAY, 1, format, width, height, layers);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_REPEAT);
  return true;
}

Status gl_status(const char* stage) {
  if (glGetGraphicsResetStatus() != GL_NO_ERROR)
    return make_error(ErrorCode::kInternal, std::string("gpu: the GL context was lost during ") + stage, "gpu");
  const GLenum e = glGetError();
  if (e == GL_NO_ERROR) return Status::Ok();
  while (glGetError() != GL_NO_ERROR) {
  }
  return make_error(e == GL_OUT_OF_MEMORY ? ErrorCode::kResourceExhausted : ErrorCode::kInternal,
                    "gpu: " + gl_error_name(e) + " during " + stage, "gpu");
}

void set_uniform(GLuint program, const char* name, int v) {
  glUniform1i(glGetUniformLocation(program, name), v);
}
void set_uniform(GLuint program, const char* name, float v) {
  glUniform1f(glGetUniformLocation(program, name), v);
}

}  // namespace horizon::gpu
