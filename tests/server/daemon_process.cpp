#include "daemon_process.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <grpcpp/support/channel_arguments.h>

#ifndef HORIZOND_PATH
#error "HORIZOND_PATH must be defined by the build"
#endif

namespace horizon::testing {
namespace {

// HORIZON_TEST_HORIZOND: another build of the daemon to run the tests against
// (scripts/tsan.sh: a ThreadSanitizer one), or null.
const char* other_horizond() {
  const char* daemon = std::getenv("HORIZON_TEST_HORIZOND");
  return daemon != nullptr && *daemon != '\0' ? daemon : nullptr;
}

int number_after(const std::string& text, const std::string& key) {
  const auto at = text.find("\"" + key + "\":");
  if (at == std::string::npos) return 0;
  return std::atoi(text.c_str() + at + key.size() + 3);
}

}  // namespace

bool another_daemon_build() { return other_horizond() != nullptr; }

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path + ".new", std::ios::binary);
  out << text;
  out.close();
  std::rename((path + ".new").c_str(), path.c_str());
}

DaemonProcess::DaemonProcess(const DaemonOptions& o) {
  config_path_ = dir_.file("horizond.json");
  log_path_ = dir_.file("horizond.log");
  std::ostringstream config;
  config << "{\"listen\": \"127.0.0.1:0\", \"metrics_listen\": \"127.0.0.1:0\",\n"
         << (o.plaintext ? " \"plaintext\": true,\n" : "")
         << " \"data_root\": \"" << o.data_root << "\",\n \"datasets\": {";
  for (std::size_t i = 0; i < o.datasets.size(); ++i)
    config << (i ? ", " : "") << "\"" << o.datasets[i].first << "\": \"" << o.datasets[i].second << "\"";
  config << "},\n " << o.extra_json << " \"memory_budget_mb\": " << o.memory_budget_mb
         << ", \"worker_threads\": " << o.worker_threads << ", \"scratch_dir\": \"" << dir_.path().string() << "\"}\n";
  write_file(config_path_, config.str());

  const char* daemon = another_daemon_build() ? other_horizond() : HORIZOND_PATH;
  pid_ = ::fork();
  if (pid_ == 0) {
    const int fd = ::open(log_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 2);
    ::close(fd);
    ::execl(daemon, "horizond", "--config", config_path_.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  if (!wait_for_log("\"event\":\"datasets_loaded\"", std::chrono::seconds(30))) {
    error_ = "horizond did not come up; its log:\n" + log();
    return;
  }
  const std::string text = log();
  port_ = number_after(text, "grpc_port");
  metrics_port_ = number_after(text, "metrics_port");
}

DaemonProcess::~DaemonProcess() {
  if (pid_ > 0 && !exited_) {
    if (signal(SIGTERM, std::chrono::seconds(20)) < 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
}

std::string DaemonProcess::log() const {
  std::ifstream in(log_path_, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::vector<std::string> DaemonProcess::request_lines() const {
  std::vector<std::string> lines;
  std::istringstream in(log());
  for (std::string line; std::getline(in, line);)
    if (line.find("\"event\":\"request\"") != std::string::npos) lines.push_back(line);
  return lines;
}

std::string DaemonProcess::metrics() const {
  return metrics_page("/metrics");
}

std::string DaemonProcess::metrics_page(const std::string& path) const {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return "";
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(metrics_port_));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string text;
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0) {
    const std::string request = "GET " + path + " HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n";
    if (::write(fd, request.data(), request.size()) == static_cast<ssize_t>(request.size())) {
      char buffer[4096];
      for (ssize_t n; (n = ::read(fd, buffer, sizeof buffer)) > 0;) text.append(buffer, static_cast<std::size_t>(n));
    }
  }
  ::close(fd);
  return text;
}

bool DaemonProcess::wait_for_in_flight(int calls, std::chrono::milliseconds timeout) const {
  return wait_for_metrics([&](const std::string& m) { return metric(m, "horizon_requests_in_flight") >= calls; },
                          timeout);
}

bool DaemonProcess::wait_for_metrics(const std::function<bool(const std::string& metrics)>& settled,
                                     std::chrono::milliseconds timeout) const {
  const auto until = std::chrono::steady_clock::now() + timeout;
  do {
    if (settled(metrics())) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  } while (std::chrono::steady_clock::now() < until);
  return false;
}

bool DaemonProcess::memory_returned() const {
  return wait_for_metrics(
      [](const std::string& m) {
        return metric(m, "horizon_memory_reserved_bytes") ==
               metric(m, "horizon_block_cache_budget_bytes") + metric(m, "horizon_receive_buffer_bytes") +
                   metric(m, "horizon_gpu_image_bytes") + metric(m, "horizon_worker_kept_bytes");
      },
      std::chrono::seconds(5));
}

double metric(const std::string& text, const std::string& series) {
  for (std::size_t at = text.find(series + " "); at != std::string::npos; at = text.find(series + " ", at + 1))
    if (at == 0 || text[at - 1] == '\n') return std::stod(text.substr(at + series.size() + 1));
  return -1;
}

std::shared_ptr<grpc::Channel> DaemonProcess::channel() const {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 << 20);
  args.SetMaxSendMessageSize(64 << 20);
  return grpc::CreateCustomChannel(address(), grpc::InsecureChannelCredentials(), args);
}

int DaemonProcess::signal(int sig, std::chrono::seconds wait) {
  if (pid_ <= 0 || exited_) return -1;
  ::kill(pid_, sig);
  if (sig != SIGTERM && sig != SIGINT) return -1;
  const auto until = std::chrono::steady_clock::now() + wait;
  while (std::chrono::steady_clock::now() < until) {
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      exited_ = true;
      return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return -1;
}

bool DaemonProcess::wait_for_log(const std::string& text, std::chrono::milliseconds timeout) const {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < until) {
    if (log().find(text) != std::string::npos) return true;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      exited_ = true;
      return log().find(text) != std::string::npos;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

namespace {

// A "Vm...:" line of /proc/PID/status, in bytes (0 when absent).
std::uint64_t status_bytes(pid_t pid, const std::string& key) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind(key, 0) == 0) return std::stoull(line.substr(key.size())) * 1024;  // kB
  return 0;
}

}  // namespace

std::uint64_t DaemonProcess::peak_rss_bytes() const {
  return status_bytes(pid_, "VmHWM:");
}

std::uint64_t DaemonProcess::rss_bytes() const {
  return status_bytes(pid_, "VmRSS:");
}

}  // namespace horizon::testing
