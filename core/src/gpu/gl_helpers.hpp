// Private to horizon_core: generic OpenGL 4.3 helpers for code that runs on a
// context borrowed from gpu::ContextPool (the GL forms of the algorithms,
// e.g. visibility/radial_sweep_gl.cpp). Nothing here knows what is drawn:
// shader compile and link with their logs, textures and storage buffers that
// only grow (so that requests of a size seen before allocate nothing), and
// GL errors turned into Status. Every call needs a current context.
#pragma once

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <string>

#include "horizon/common/error.hpp"

namespace horizon::gpu {

// Bytes a texel of an internal format takes (R32F 4, RG32F 8, RGBA32F 16,
// R8UI 1, ...); 16 for a format not listed, an upper bound.
std::uint64_t texel_bytes(GLenum internal_format);

// Bytes a host vector that GL code keeps holds after growing to `count`
// elements (it never shrinks).
template <class V>
std::uint64_t vector_bytes_after(const V& v, std::size_t count) {
  return std::max<std::uint64_t>(v.capacity(), count) * sizeof(typename V::value_type);
}

// A compiled shader of `type`, or 0 with the compiler's log in `log`.
GLuint compile_shader(GLenum type, const std::string& source, std::string& log);

// The program linked from `shaders` (which are deleted either way), or 0 with
// the linker's log in `log`.
GLuint link_program(std::initializer_list<GLuint> shaders, std::string& log);

// A 2D texture of one level that only grows: glTexStorage2D is immutable, so
// growing re-creates it; a request of a size seen before reuses it. Nearest
// filtering (texels are read with texelFetch or as images).
struct Texture2D {
  GLuint texture = 0;
  GLenum format = GL_R32F;
  int width = 0, height = 0;

  explicit Texture2D(GLenum internal_format) : format(internal_format) {}
  Texture2D(const Texture2D&) = delete;
  Texture2D& operator=(const Texture2D&) = delete;
  ~Texture2D();
  // At least w x h texels (contents undefined after a growth).
  void ensure(int w, int h);
  // Bytes held now, and after ensure(w, h).
  std::uint64_t bytes() const { return bytes_after(0, 0); }
  std::uint64_t bytes_after(int w, int h) const;
  // Deletes the texture (the next ensure re-creates it).
  void release();
};

// A shader storage buffer that only grows; an upload that fits reuses it.
struct StorageBuffer {
  GLuint id = 0;
  std::size_t capacity = 0;  // bytes

  StorageBuffer() = default;
  StorageBuffer(const StorageBuffer&) = delete;
  StorageBuffer& operator=(const StorageBuffer&) = delete;
  ~StorageBuffer();
  // Binds the buffer to `binding` of GL_SHADER_STORAGE_BUFFER and copies `bytes` in.
  void upload(GLuint binding, const void* data, std::size_t bytes);
  // Binds it with room for at least `bytes` (contents undefined after a growth).
  void reserve(GLuint binding, std::size_t bytes);
  // Copies its first `bytes` out (waits for the writes before it).
  void download(void* data, std::size_t bytes) const;
  // Bytes held now, and after an upload or reserve of `bytes`.
  std::uint64_t held() const { return capacity; }
  std::uint64_t held_after(std::size_t bytes) const { return bytes > capacity ? std::max(bytes, 2 * capacity) : capacity; }
  // Deletes the buffer (the next upload or reserve re-creates it).
  void release();
};

// A 2D texture array of one mip level, w x h x layers, re-created whenever
// its shape changes. Nearest filtering, GL_REPEAT wrapping.
struct TextureArray {
  GLuint texture = 0;
  GLenum format = GL_R32F;
  int width = 0, height = 0, layers = 0;

  explicit TextureArray(GLenum internal_format) : format(internal_format) {}
  TextureArray(const TextureArray&) = delete;
  TextureArray& operator=(const TextureArray&) = delete;
  ~TextureArray();
  // Exactly w x h x layers texels; true when it was (re-)created (contents undefined).
  bool ensure(int w, int h, int layer_count);
  // Bytes held now, and after ensure(w, h, layers).
  std::uint64_t bytes() const;
  std::uint64_t bytes_after(int w, int h, int layer_count) const;
  // Deletes the texture (the next ensure re-creates it).
  void release();
};

// Ok, or the first pending GL error (the rest are drained) or a lost context,
// as an error naming `stage`: kResourceExhausted for GL_OUT_OF_MEMORY,
// kInternal otherwise.
Status gl_status(const char* stage);

void set_uniform(GLuint program, const char* name, int v);
void set_uniform(GLuint program, const char* name, float v);

}  // namespace horizon::gpu
