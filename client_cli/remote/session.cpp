// `horizon session DATASET --server HOST:PORT ...`: the flight played over one
// SessionService stream, reported as embedded mode reports its own.
#include <chrono>
#include <mutex>
#include <thread>

#include "commands/command.hpp"
#include "commands/session.hpp"
#include "remote/client.hpp"
#include "remote/module_abi.hpp"

namespace horizon::cli::remote {
namespace {

using Stream = grpc::ClientReaderWriter<v1::SessionRequest, v1::SessionResponse>;

v1::Pose to_proto_pose(const clipmap::SessionPose& p) {
  v1::Pose out;
  *out.mutable_position() = to_proto_point(p.position);
  out.set_east_m_per_s(p.east_per_s);
  out.set_north_m_per_s(p.north_per_s);
  out.set_seq(p.seq);
  return out;
}

PoseLine to_line(const v1::SessionResponse& r) {
  PoseLine line;
  if (r.has_rejected()) {
    line.seq = r.rejected().seq();
    line.rejected = r.rejected().message();
    return line;
  }
  const v1::PoseAnswer& a = r.answer();
  line.seq = a.seq();
  line.dropped = a.poses_dropped();
  line.changes = static_cast<std::size_t>(a.changes_size());
  line.boxes = a.boxes();
  line.visible = a.visible();
  line.samples = a.samples();
  line.fallbacks = a.fallbacks();
  line.subtiles_loaded = a.subtiles_loaded();
  line.bytes_loaded = a.bytes_loaded();
  line.seconds = a.seconds();
  if (a.has_viewshed()) line.viewshed = {a.viewshed().visible_cells(), a.viewshed().hidden_cells()};
  line.gpu = a.backend() == "gpu";
  line.gpu_fallback = a.gpu_fallback();
  return line;
}

}  // namespace

int impl::run_session(const Args& args, const SessionPlayback& playback, bool json, bool every_pose) {
  Client client(args);
  const auto started = std::chrono::steady_clock::now();
  const clipmap::SessionOptions& o = playback.options;
  v1::SessionRequest open;
  v1::OpenSession* m = open.mutable_open();
  m->set_dataset(playback.dataset);
  m->mutable_clipmap()->set_levels(static_cast<std::uint32_t>(o.shape.levels));
  m->mutable_clipmap()->set_level_size(static_cast<std::uint32_t>(o.shape.level_size));
  m->mutable_clipmap()->set_subtile(static_cast<std::uint32_t>(o.shape.subtile));
  m->set_mode(o.mode == clipmap::ClipMode::kConservative ? v1::SESSION_MODE_CONSERVATIVE
              : o.mode == clipmap::ClipMode::kExact      ? v1::SESSION_MODE_EXACT
                                                         : v1::SESSION_MODE_FAST);
  m->set_rays(static_cast<std::uint32_t>(o.rays));
  if (o.viewshed_radius > 0.0) m->set_viewshed_radius_m(o.viewshed_radius);
  if (o.use_gpu) m->set_backend(v1::BACKEND_GPU);
  *m->mutable_first_pose() = to_proto_pose(playback.poses.front());
  for (const clipmap::SessionBox& b : playback.boxes) {
    v1::SessionBox* out = m->add_boxes();
    out->set_id(b.id);
    *out->mutable_box() = to_proto_box(b.box);
  }

  // A session lasts as long as its flight: only an explicit --deadline bounds it.
  auto context = client.context();
  if (!args.has("--deadline")) context->set_deadline(std::chrono::system_clock::time_point::max());
  if (auto id = args.text("--session-id")) context->AddMetadata("horizon-session-id", *id);
  std::unique_ptr<Stream> stream = client.sessions().Session(context.get());
  SessionReport report;
  report.where = "on " + client.address();
  v1::SessionResponse r;
  if (!stream->Write(open) || !stream->Read(&r) || !r.has_opened()) {
    stream->WritesDone();
    while (stream->Read(&r)) {
    }
    return report_status(stream->Finish(), client.address());
  }
  report.levels = static_cast<int>(r.opened().clipmap().levels());
  report.level_size = static_cast<int>(r.opened().clipmap().level_size());
  report.subtile = static_cast<int>(r.opened().clipmap().subtile());
  report.memory_bytes = r.opened().memory_bytes();
  report.session_id = r.opened().session_id();

  // The first pose is answered at open. With a rate, a writer sends the rest
  // on the clock while this thread reads; without, each waits for its answer.
  std::mutex mutex;
  auto read_one = [&]() {
    v1::SessionResponse in;
    if (!stream->Read(&in)) return false;
    if (in.has_answer() || in.has_rejected()) {
      std::lock_guard lock(mutex);
      report.poses.push_back(to_line(in));
    }
    return true;
  };
  if (!read_one()) return report_status(stream->Finish(), client.address());
  if (playback.rate_hz > 0.0) {
    std::thread writer([&] {
      const auto flight = std::chrono::steady_clock::now();
      for (std::size_t i = 1; i < playback.poses.size(); ++i) {
        std::this_thread::sleep_until(flight + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                   std::chrono::duration<double>(double(i) / playback.rate_hz)));
        v1::SessionRequest req;
        *req.mutable_pose() = to_proto_pose(playback.poses[i]);
        if (!stream->Write(req)) break;
      }
      stream->WritesDone();
    });
    while (read_one()) {
    }
    writer.join();
  } else {
    for (std::size_t i = 1; i < playback.poses.size(); ++i) {
      v1::SessionRequest req;
      *req.mutable_pose() = to_proto_pose(playback.poses[i]);
      if (!stream->Write(req) || !read_one()) break;
    }
    stream->WritesDone();
    while (read_one()) {
    }
  }
  const grpc::Status status = stream->Finish();
  if (!status.ok()) return report_status(status, client.address());
  report.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  print_session(playback, report, json, every_pose);
  return kExitOk;
}

}  // namespace horizon::cli::remote
