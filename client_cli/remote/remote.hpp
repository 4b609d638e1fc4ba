// remote.hpp — `horizon ... --server HOST:PORT`: the same commands answered by
// a horizond daemon. The DEM operand is then a dataset name. Each command
// parses and checks its flags exactly as in embedded mode, then hands the
// parsed request here; the output (files, text, JSON) is the same as
// embedded mode's, and the GeoTIFF byte-identical for the same algorithm.
// gRPC stays inside client_cli/remote/, which is built as the plugin
// libhorizon_remote.so: the run_* below are the executable's forwarders
// (remote_loader.cpp), which open it on first use (module_abi.hpp says why
// and how; HORIZON_REMOTE_PLUGIN names the module's path explicitly).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "args.hpp"
#include "commands/viewshed_raster.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/geotiff_options.hpp"
#include "horizon/terrain/height_edit.hpp"
#include "horizon/trace/camera.hpp"
#include "horizon/trace/trace.hpp"
#include "horizon/visibility/cull.hpp"
#include "horizon/visibility/line_of_sight.hpp"
#include "horizon/visibility/options.hpp"
#include "observers_file.hpp"

namespace horizon::cli {
struct SessionPlayback;
}

namespace horizon::cli::remote {

// The flags every remote-capable command adds to its table.
inline constexpr FlagSpec kServerFlag{"--server", "", "HOST:PORT",
                                      "Ask the horizond daemon there; the DEM operand is then a dataset name"};
inline constexpr FlagSpec kDeadlineFlag{
    "--deadline", "", "S", "With --server: seconds the daemon may take (default 60); the call fails after"};
inline constexpr FlagSpec kCaFlag{"--ca", "", "CA.pem",
                                  "With --server: speak TLS, trusting the daemon's certificate to this CA"};
inline constexpr FlagSpec kClientCertFlag{"--client-cert", "", "CERT.pem,KEY.pem",
                                          "With --ca: present this client certificate and key (mutual TLS)"};
inline constexpr FlagSpec kTokenFileFlag{
    "--token-file", "", "FILE", "With --server: send the bearer token in FILE's first line (or $HORIZON_TOKEN)"};

struct ViewshedInputs {
  std::string dataset;
  std::string out_path;
  std::optional<std::string> png_path;
  geodesy::PointSpec observer;
  visibility::ViewshedOptions options;
  terrain::TiffFormat format = terrain::TiffFormat::kGTiff;
  std::vector<std::string> creation_options;  // as typed; the daemon parses them as the CLI did
  RasterFlags raster;                         // the raster, its codes and -a_nodata
  std::string algorithm_name;  // as given
  bool json = false;
};

// `horizon viewshed DATASET --server ... --observers FILE`: as embedded
// mode's many observers (viewshed_many.cpp), computed by the daemon.
struct ManyViewshedInputs {
  std::string dataset, out_path, accumulate;  // "count", "any", "all"
  std::optional<std::string> png_path, summary_path;
  std::vector<NamedObserver> observers;
  visibility::ViewshedOptions options;
  terrain::TiffFormat format = terrain::TiffFormat::kGTiff;
  std::vector<std::string> creation_options;
  std::string algorithm_name;
  bool json = false;
};

// One `horizon trace --edit`: a rectangle in the DEM's CRS (the cells whose
// centres it holds) set to, or raised by, `height` metres.
struct TraceEditRect {
  double x_min, y_min, x_max, y_max;
  terrain::EditMode mode;
  float height;
};

// `horizon trace DATASET --server ...`: one frame traced by the daemon
// (TraceService.TraceCamera); the same files and report as embedded mode.
struct TraceInputs {
  std::string dataset;
  std::optional<std::string> depth_path, png_path, hits_path, footprint_path;
  trace::CameraSpec camera;
  trace::TraceOptions options;  // threads: the daemon's
  std::vector<visibility::BoxSpec> boxes;
  std::vector<std::uint64_t> box_ids;  // one per box, or none
  std::vector<TraceEditRect> edits;
  bool json = false;
  bool gpu = false;  // --backend gpu: on one of the daemon's GL contexts
};

int run_info(const Args& args, const std::string& dataset, bool json);
int run_viewshed_many(const Args& args, const ManyViewshedInputs& inputs);
int run_viewshed(const Args& args, const ViewshedInputs& inputs);
int run_los(const Args& args, const std::string& dataset, const geodesy::PointSpec& from, const geodesy::PointSpec& to,
            const visibility::LosOptions& options, bool json);
// The boxes (and their ids, one each or none) as read by `horizon cull`;
// prints the same report as embedded mode.
int run_cull(const Args& args, const std::string& dataset, const geodesy::PointSpec& observer,
             const std::vector<visibility::BoxSpec>& boxes, const std::vector<std::uint64_t>& ids,
             const visibility::CullOptions& options, bool json);
int run_datasets(const Args& args, bool json);
// `horizon mesh cull MESH --server ...`: one CullMesh call (and a
// DescribeMesh for the mesh's facts); prints what embedded mode prints.
struct MeshCullInputs {
  std::string mesh;
  geodesy::PointSpec observer;
  std::optional<double> azimuth_from, azimuth_to;
  bool conservative = false;
  bool boxes = false;  // the mesh's registered boxes too
  bool json = false;
};
int run_mesh_cull(const Args& args, const MeshCullInputs& inputs);
int run_trace(const Args& args, const TraceInputs& inputs);
// The flight over one session stream; prints the same report as embedded mode.
int run_session(const Args& args, const SessionPlayback& playback, bool json, bool every_pose);

}  // namespace horizon::cli::remote
