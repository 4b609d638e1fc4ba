// session.hpp — `horizon session`: a flight path played through a clip-map
// session, embedded or on a daemon (--server), reported alike.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "horizon/clipmap/session.hpp"

namespace horizon::cli {

// What the command plays: the poses (seq = line number order, from 1) and
// boxes (id = line order, from 1) as read, and the session's options
// (shape.levels 0: the fewest levels that cover the dataset).
struct SessionPlayback {
  std::string dataset;  // the DEM path, or the dataset name
  std::string poses_path, boxes_path;
  std::vector<clipmap::SessionPose> poses;
  std::vector<clipmap::SessionBox> boxes;
  clipmap::SessionOptions options;
  double rate_hz = 0.0;  // 0: each pose once the last is answered
};

// One answered (or rejected) pose.
struct PoseLine {
  std::uint64_t seq = 0, dropped = 0;
  std::size_t changes = 0, boxes = 0, visible = 0;
  std::uint64_t samples = 0, fallbacks = 0, subtiles_loaded = 0, bytes_loaded = 0;
  double seconds = 0.0;  // the engine's time for it (the server's, with --server)
  // With --viewshed-radius: cells within it {seen, hidden}.
  std::optional<std::array<std::uint64_t, 2>> viewshed;
  std::string rejected;  // why, when the pose was rejected
  bool gpu = false;           // its trace ran on a GL context
  std::string gpu_fallback;   // with --backend gpu: why it ran on the CPU
};

struct SessionReport {
  std::string where;  // "" embedded, else "on HOST:PORT"
  std::string session_id;  // the daemon's, with --server
  int levels = 0, level_size = 0, subtile = 0;
  std::uint64_t memory_bytes = 0;
  std::vector<PoseLine> poses;
  double total_seconds = 0.0;
};

// Text: a summary (and with `every_pose` a line a pose); JSON: the summary and "poses".
void print_session(const SessionPlayback& playback, const SessionReport& report, bool json, bool every_pose);

}  // namespace horizon::cli
