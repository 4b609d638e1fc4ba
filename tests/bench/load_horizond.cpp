// load_horizond — a bounded, loopback load generator for horizond.
//
//   load_horizond --server 127.0.0.1:50051 --dataset everest --mode viewshed|cull|mixed|mesh
//                 --x X --y Y [--clients 2] [--requests 200 | --seconds S] [--max-distance 10000]
//                 [--boxes 10000] [--scene-radius 3000] [--spread 500] [--seed 1] [--retry 1]
//                 [--mesh NAME] [--conservative 1]
//
// viewshed: each request a 10 km (--max-distance) viewshed of the dataset,
//   the raw uint8 raster streamed back, from a viewpoint drawn within
//   --spread metres of X,Y (each axis).
// cull: each request a new viewpoint (within --scene-radius/2 of X,Y) and
//   --boxes object boxes (5-40 m wide, 5-30 m tall, on the ground) scattered
//   within --scene-radius of X,Y, conservative flag off (fast OHF).
// mixed: viewshed, cull and a LineOfSight of 10 lines (within --scene-radius)
//   in turn.
// mesh: each request a CullMesh of the mesh --mesh names from a new
//   viewpoint within --scene-radius/2 of X,Y (its CRS), 2 m up, all round,
//   approximate (--conservative 1: conservative); a simulator's frames.
// --seconds: run for that long (at most 3600) instead of --requests calls.
// --retry 1: the channel's service config retries UNAVAILABLE up to 4
//   attempts (50 ms backoff doubling to 500 ms), as a client of replicas
//   behind a load balancer would.
// Prints latency p50/p90/p99/max in ms and requests per second; fixed seed.
// Refusals (RESOURCE_EXHAUSTED, UNAVAILABLE) are counted apart from errors;
// the exit status is 1 when any other error occurred.
// Bounded: --requests in all (at most 100 000), loopback only by intent.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <grpcpp/support/channel_arguments.h>

#include "horizon/v1/datasets.grpc.pb.h"
#include "horizon/v1/mesh.grpc.pb.h"
#include "horizon/v1/visibility.grpc.pb.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Options {
  std::string server = "127.0.0.1:50051", dataset = "everest", mode = "cull", mesh;
  double x = 0, y = 0, max_distance = 10000, scene_radius = 3000, spread = 500, seconds = 0;
  int clients = 2, requests = 200, boxes = 10000;
  bool retry = false, conservative = false;
  unsigned seed = 1;
};

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--server")
      o.server = v;
    else if (k == "--dataset")
      o.dataset = v;
    else if (k == "--mode")
      o.mode = v;
    else if (k == "--x")
      o.x = std::atof(v.c_str());
    else if (k == "--y")
      o.y = std::atof(v.c_str());
    else if (k == "--max-distance")
      o.max_distance = std::atof(v.c_str());
    else if (k == "--scene-radius")
      o.scene_radius = std::atof(v.c_str());
    else if (k == "--spread")
      o.spread = std::atof(v.c_str());
    else if (k == "--clients")
      o.clients = std::max(1, std::atoi(v.c_str()));
    else if (k == "--requests")
      o.requests = std::clamp(std::atoi(v.c_str()), 1, 100000);
    else if (k == "--boxes")
      o.boxes = std::clamp(std::atoi(v.c_str()), 1, 100000);
    else if (k == "--seconds")
      o.seconds = std::clamp(std::atof(v.c_str()), 0.0, 3600.0);
    else if (k == "--retry")
      o.retry = v == "1";
    else if (k == "--mesh")
      o.mesh = v;
    else if (k == "--conservative")
      o.conservative = v == "1";
    else if (k == "--seed")
      o.seed = static_cast<unsigned>(std::atoi(v.c_str()));
    else {
      std::fprintf(stderr, "load_horizond: unknown flag %s\n", k.c_str());
      std::exit(2);
    }
  }
  if (o.mode == "mesh" && o.mesh.empty()) {
    std::fprintf(stderr, "load_horizond: --mode mesh needs --mesh NAME\n");
    std::exit(2);
  }
  return o;
}

horizon::v1::Point eye(double x, double y) {
  horizon::v1::Point p;
  p.set_frame(horizon::v1::FRAME_DATASET_CRS);
  p.set_x(x);
  p.set_y(y);
  p.set_height(2);
  return p;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 << 20);
  args.SetMaxSendMessageSize(64 << 20);
  if (o.retry)
    args.SetServiceConfigJSON(R"({"methodConfig": [{"name": [{"service": "horizon.v1.VisibilityService"}],
      "retryPolicy": {"maxAttempts": 4, "initialBackoff": "0.05s", "maxBackoff": "0.5s",
                      "backoffMultiplier": 2, "retryableStatusCodes": ["UNAVAILABLE"]}}]})");

  // Boxes stand 5-30 m tall on a base drawn in 4500-6500 m, the elevation band
  // of the Everest scene (a base under the terrain is simply a hidden box).
  std::vector<std::thread> threads;
  std::vector<std::vector<double>> latencies(static_cast<std::size_t>(o.clients));
  std::atomic<int> next{0}, errors{0}, refusals{0};
  const auto started = Clock::now();
  const auto until = started + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.seconds));
  for (int c = 0; c < o.clients; ++c) {
    threads.emplace_back([&, c] {
      auto channel = grpc::CreateCustomChannel(o.server, grpc::InsecureChannelCredentials(), args);
      auto stub = horizon::v1::VisibilityService::NewStub(channel);
      auto meshes = horizon::v1::MeshService::NewStub(channel);
      std::mt19937 rng(o.seed * 1000 + static_cast<unsigned>(c));
      std::uniform_real_distribution<double> unit(-1.0, 1.0), size(5.0, 40.0), tall(5.0, 30.0), ground(4500.0, 6500.0);
      horizon::v1::CullBoxesRequest cull;
      cull.set_dataset(o.dataset);
      for (int i;;) {
        i = next.fetch_add(1);
        if (o.seconds > 0 ? Clock::now() >= until : i >= o.requests) break;
        const std::string kind = o.mode != "mixed" ? o.mode : (i % 3 == 0 ? "viewshed" : i % 3 == 1 ? "cull" : "lines");
        auto t0 = Clock::now();
        grpc::ClientContext context;
        context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
        grpc::Status status;
        if (kind == "mesh") {
          horizon::v1::CullMeshRequest r;
          r.set_mesh(o.mesh);
          *r.mutable_observer() = eye(o.x + o.scene_radius / 2 * unit(rng), o.y + o.scene_radius / 2 * unit(rng));
          r.set_mode(o.conservative ? horizon::v1::CULL_MODE_CONSERVATIVE : horizon::v1::CULL_MODE_APPROXIMATE);
          horizon::v1::CullMeshResponse response;
          status = meshes->CullMesh(&context, r, &response);
        } else if (kind == "lines") {
          horizon::v1::LineOfSightRequest r;
          r.set_dataset(o.dataset);
          for (int l = 0; l < 10; ++l) {
            horizon::v1::SightLine* line = r.add_lines();
            *line->mutable_from() = eye(o.x + o.scene_radius / 2 * unit(rng), o.y + o.scene_radius / 2 * unit(rng));
            *line->mutable_to() = eye(o.x + o.scene_radius * unit(rng), o.y + o.scene_radius * unit(rng));
          }
          horizon::v1::LineOfSightResponse response;
          status = stub->LineOfSight(&context, r, &response);
        } else if (kind == "viewshed") {
          horizon::v1::ViewshedRequest r;
          r.set_dataset(o.dataset);
          *r.mutable_observer() = eye(o.x + o.spread * unit(rng), o.y + o.spread * unit(rng));
          r.mutable_options()->set_max_distance(o.max_distance);
          r.set_include_raster(true);
          auto reader = stub->ComputeViewshed(&context, r);
          horizon::v1::ViewshedResponse m;
          while (reader->Read(&m)) {
          }
          status = reader->Finish();
        } else {
          cull.clear_boxes();
          *cull.mutable_observer() = eye(o.x + o.scene_radius / 2 * unit(rng), o.y + o.scene_radius / 2 * unit(rng));
          for (int b = 0; b < o.boxes; ++b) {
            const double bx = o.x + o.scene_radius * unit(rng), by = o.y + o.scene_radius * unit(rng);
            const double w = size(rng), z = ground(rng);
            horizon::v1::Box* box = cull.add_boxes();
            box->set_x_min(bx);
            box->set_y_min(by);
            box->set_x_max(bx + w);
            box->set_y_max(by + w);
            box->set_z_min(z);
            box->set_z_max(z + tall(rng));
          }
          horizon::v1::CullBoxesResponse response;
          t0 = Clock::now();  // the call itself, not building the 10 000 boxes
          status = stub->CullBoxes(&context, cull, &response);
        }
        if (!status.ok()) {
          const bool refused = status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED ||
                               status.error_code() == grpc::StatusCode::UNAVAILABLE;
          if ((refused ? refusals : errors).fetch_add(1) == 0)
            std::fprintf(stderr, "load_horizond: %s: %s\n", refused ? "refused" : "error",
                         status.error_message().c_str());
          continue;
        }
        latencies[static_cast<std::size_t>(c)].push_back(
            std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      }
    });
  }
  for (auto& t : threads) t.join();
  const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
  std::vector<double> all;
  for (auto& l : latencies) all.insert(all.end(), l.begin(), l.end());
  std::sort(all.begin(), all.end());
  auto pct = [&](double p) {
    return all.empty() ? 0.0 : all[std::min(all.size() - 1, static_cast<std::size_t>(p * all.size()))];
  };
  std::printf(
      "mode %s: %zu ok, %d errors, %d refused, %d clients, %.2f s: %.1f req/s; latency ms p50 %.2f p90 %.2f p99 %.2f "
      "max %.2f\n",
      o.mode.c_str(), all.size(), errors.load(), refusals.load(), o.clients, seconds,
      static_cast<double>(all.size()) / seconds, pct(0.50), pct(0.90), pct(0.99), all.empty() ? 0.0 : all.back());
  return errors.load() == 0 ? 0 : 1;
}
