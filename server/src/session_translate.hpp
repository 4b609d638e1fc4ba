// session_translate.hpp — session.proto messages to and from the engine's
// clip-map sessions (core/clipmap/session.hpp). Fields are named by their API
// path ("open.clipmap.levels", "boxes.add[3].id", "pose.position").
#pragma once

#include <string>
#include <vector>

#include "config.hpp"
#include "horizon/clipmap/session.hpp"
#include "horizon/v1/session.pb.h"

namespace horizon::server {

// An OpenSession's options, with the server's defaults filled in and its
// limits applied (sessions.max_level_size, sessions.max_boxes); the
// dataset's width x height decides the default number of levels.
// BACKEND_GPU asks for the trace on `gpu` (the daemon's contexts, null when
// it has none: the answers then say so in gpu_fallback).
Result<clipmap::SessionOptions> to_session_options(const v1::OpenSession& open, const SessionConfig& config,
                                                   unsigned threads, int width, int height,
                                                   gpu::ContextPool* gpu);
// A pose; `field` is its path ("pose", "open.first_pose").
Result<clipmap::SessionPose> to_session_pose(const v1::Pose& pose, const std::string& field);
// Boxes with their ids; `field` is the list's path ("boxes.add", "open.boxes").
Result<std::vector<clipmap::SessionBox>> to_session_boxes(
    const google::protobuf::RepeatedPtrField<v1::SessionBox>& boxes, const std::string& field);

void fill_shape(const clipmap::SessionOptions& options, v1::ClipmapShape& out);
void fill_answer(const clipmap::SessionAnswer& answer, std::uint64_t dropped, v1::PoseAnswer& out);

}  // namespace horizon::server
