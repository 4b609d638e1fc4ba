#!/usr/bin/env python3
"""An independent client: Debian's python3-grpcio with no Horizon .proto file.

It starts a real horizond on an ephemeral loopback port, learns the API through
server reflection (grpc.reflection.v1alpha), builds message classes from the
descriptors the daemon serves, and calls every RPC; then checks error details
(google.rpc.Status in grpc-status-details-bin), a client cancelling
mid-stream, the standard health service and the Prometheus endpoint.
"""
import argparse
import json
import os
import queue
import signal
import struct
import subprocess
import sys
import tempfile
import time
import urllib.request

import grpc
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory


def reflection_classes():
    """ServerReflectionRequest/Response classes, declared here (the reflection
    proto is not shipped by Debian): only the fields this client uses."""
    f = descriptor_pb2.FileDescriptorProto(name="reflection_subset.proto", package="grpc.reflection.v1alpha",
                                           syntax="proto3")
    T = descriptor_pb2.FieldDescriptorProto
    def msg(name, fields):
        m = f.message_type.add(name=name)
        for fname, number, ftype, label, type_name in fields:
            fd = m.field.add(name=fname, number=number, type=ftype, label=label)
            if type_name:
                fd.type_name = type_name
        return m
    opt, rep = T.LABEL_OPTIONAL, T.LABEL_REPEATED
    msg("ServerReflectionRequest", [("host", 1, T.TYPE_STRING, opt, None),
                                    ("file_by_filename", 3, T.TYPE_STRING, opt, None),
                                    ("file_containing_symbol", 4, T.TYPE_STRING, opt, None),
                                    ("list_services", 7, T.TYPE_STRING, opt, None)])
    msg("FileDescriptorResponse", [("file_descriptor_proto", 1, T.TYPE_BYTES, rep, None)])
    msg("ServiceResponse", [("name", 1, T.TYPE_STRING, opt, None)])
    msg("ListServiceResponse", [("service", 1, T.TYPE_MESSAGE, rep, ".grpc.reflection.v1alpha.ServiceResponse")])
    msg("ErrorResponse", [("error_code", 1, T.TYPE_INT32, opt, None), ("error_message", 2, T.TYPE_STRING, opt, None)])
    msg("ServerReflectionResponse", [
        ("valid_host", 1, T.TYPE_STRING, opt, None),
        ("file_descriptor_response", 4, T.TYPE_MESSAGE, opt, ".grpc.reflection.v1alpha.FileDescriptorResponse"),
        ("list_services_response", 6, T.TYPE_MESSAGE, opt, ".grpc.reflection.v1alpha.ListServiceResponse"),
        ("error_response", 7, T.TYPE_MESSAGE, opt, ".grpc.reflection.v1alpha.ErrorResponse")])
    pool = descriptor_pool.DescriptorPool()
    pool.Add(f)
    factory = message_factory.MessageFactory(pool)
    get = lambda n: factory.GetPrototype(pool.FindMessageTypeByName("grpc.reflection.v1alpha." + n))
    return get("ServerReflectionRequest"), get("ServerReflectionResponse")


class Api:
    """Message classes and callables for every method the daemon reflects."""

    def __init__(self, channel):
        Req, Resp = reflection_classes()
        reflect = channel.stream_stream("/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo",
                                        request_serializer=Req.SerializeToString,
                                        response_deserializer=Resp.FromString)
        ask = lambda **kw: next(iter(reflect(iter([Req(**kw)]), timeout=10)))
        self.services = [s.name for s in ask(list_services="*").list_services_response.service]
        self.pool = descriptor_pool.DescriptorPool()
        seen = set()

        def add_file(proto_bytes):
            fd = descriptor_pb2.FileDescriptorProto.FromString(proto_bytes)
            if fd.name in seen:
                return
            for dep in fd.dependency:
                if dep not in seen:
                    for b in ask(file_by_filename=dep).file_descriptor_response.file_descriptor_proto:
                        add_file(b)
            if fd.name not in seen:
                seen.add(fd.name)
                self.pool.Add(fd)

        wanted = [s for s in self.services if s.startswith("horizon.")]
        for name in wanted + ["google.rpc.Status", "google.rpc.BadRequest"]:
            r = ask(file_containing_symbol=name)
            assert not r.HasField("error_response"), (name, r.error_response.error_message)
            for b in r.file_descriptor_response.file_descriptor_proto:
                add_file(b)
        self.factory = message_factory.MessageFactory(self.pool)
        self.channel = channel

    def cls(self, full_name):
        return self.factory.GetPrototype(self.pool.FindMessageTypeByName(full_name))

    def method(self, service, name):
        m = self.pool.FindServiceByName(service).FindMethodByName(name)
        out = self.cls(m.output_type.full_name)
        make = self.channel.unary_stream if m.server_streaming else self.channel.unary_unary
        return self.cls(m.input_type.full_name), make("/%s/%s" % (service, name),
                                                     request_serializer=lambda x: x.SerializeToString(),
                                                     response_deserializer=out.FromString)

    def details(self, error):
        """(code name, first violated field) from a failed call's google.rpc.Status."""
        Status, BadRequest = self.cls("google.rpc.Status"), self.cls("google.rpc.BadRequest")
        for key, value in error.trailing_metadata() or ():
            if key == "grpc-status-details-bin":
                status = Status.FromString(value)
                for any_ in status.details:
                    if any_.type_url.endswith("google.rpc.BadRequest"):
                        bad = BadRequest.FromString(any_.value)
                        return error.code().name, bad.field_violations[0].field
        return error.code().name, ""


def start_daemon(horizond, data_dir, tmp):
    config = os.path.join(tmp, "horizond.json")
    with open(config, "w") as f:
        json.dump({"listen": "127.0.0.1:0", "plaintext": True, "metrics_listen": "127.0.0.1:0", "data_root": data_dir,
                   "datasets": {"rainier": "rainier_summit_srtm3_400x400.tif",
                                "everest": "everest_summit_voids_srtm3_300x300.tif",
                                "olinda": "olinda_coast_utm25s_111x111.tif"},
                   "memory_budget_mb": 128, "worker_threads": 2, "scratch_dir": tmp,
                   "limits": {"max_lines": 20}}, f)
    log_path = os.path.join(tmp, "horizond.log")
    log = open(log_path, "w")
    proc = subprocess.Popen([horizond, "--config", config], stderr=log)
    for _ in range(500):
        text = open(log_path).read()
        if '"datasets_loaded"' in text:
            break
        time.sleep(0.02)
    listening = json.loads(next(l for l in text.splitlines() if '"listening"' in l))
    return proc, listening, log_path


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--horizond", required=True)
    parser.add_argument("--data-dir", required=True)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="horizond-py-") as tmp:
        log_path = os.path.join(tmp, "horizond.log")
        try:
            proc, listening, log_path = start_daemon(args.horizond, args.data_dir, tmp)
            try:
                run_checks(listening, log_path)
            finally:
                proc.send_signal(signal.SIGTERM)
                code = proc.wait(timeout=30)
            assert code == 0, "horizond exited %d" % code
            assert '"level":"error"' not in open(log_path).read()
        except BaseException:
            # The daemon's side of a failure, for whoever reads the test log.
            if os.path.exists(log_path):
                sys.stderr.write("--- horizond log ---\n" + open(log_path).read()[-6000:] + "\n")
            raise
    print("ok: Python reflection client")


def run_checks(listening, log_path):
    channel = grpc.insecure_channel("127.0.0.1:%d" % listening["grpc_port"])
    api = Api(channel)
    assert "horizon.v1.DatasetService" in api.services and "horizon.v1.VisibilityService" in api.services, api.services
    assert "grpc.health.v1.Health" in api.services, api.services

    # Health: the standard service, SERVING once datasets are loaded (raw bytes:
    # HealthCheckRequest{service}, HealthCheckResponse{status = 1 SERVING}).
    health = channel.unary_unary("/grpc.health.v1.Health/Check", request_serializer=lambda b: b,
                                 response_deserializer=lambda b: b)
    assert health(b"", timeout=5) == b"\x08\x01"
    name = b"horizon.v1.VisibilityService"
    assert health(b"\x0a" + bytes([len(name)]) + name, timeout=5) == b"\x08\x01"
    try:
        health(b"\x0a\x04nope", timeout=5)
        raise AssertionError("unknown service should be NOT_FOUND")
    except grpc.RpcError as e:
        assert e.code() == grpc.StatusCode.NOT_FOUND

    # Datasets, paginated.
    ListReq, list_datasets = api.method("horizon.v1.DatasetService", "ListDatasets")
    names, token = [], ""
    while True:
        page = list_datasets(ListReq(page_size=2, page_token=token), timeout=10)
        names += [d.name for d in page.datasets]
        token = page.next_page_token
        if not token:
            break
    assert names == ["everest", "olinda", "rainier"], names
    GetReq, get_dataset = api.method("horizon.v1.DatasetService", "GetDataset")
    rainier = get_dataset(GetReq(name="rainier"), timeout=10)
    assert (rainier.width, rainier.height, rainier.epsg) == (400, 400, 4326)
    assert rainier.resident_bytes == 400 * 400 * 4

    # Viewshed: header, raster rows in order, GeoTIFF bytes, summary.
    VsReq, viewshed = api.method("horizon.v1.VisibilityService", "ComputeViewshed")
    Point = api.cls("horizon.v1.Point")
    eye = Point(frame=2, x=-121.7604, y=46.8529, height=2)
    request = VsReq(dataset="rainier", observer=eye, include_raster=True, include_geotiff=True, max_chunk_bytes=8192)
    request.options.max_distance = 6000
    header, rows, tif, summary = None, 0, b"", None
    raster = b""
    for m in viewshed(request, timeout=30):
        part = m.WhichOneof("part")
        if part == "header":
            header = m.header
        elif part == "raster_chunk":
            assert m.raster_chunk.row0 == rows
            rows += m.raster_chunk.rows
            raster += m.raster_chunk.data
        elif part == "file_chunk":
            assert m.file_chunk.offset == len(tif)
            tif += m.file_chunk.data
        else:
            summary = m.summary
    assert header and summary and rows == header.height
    assert len(raster) == header.width * header.height
    assert raster.count(1) == summary.visible_cells and raster.count(0) == summary.hidden_cells
    assert tif[:4] in (b"II*\x00", b"II+\x00"), tif[:4]
    assert summary.visible_cells > 0

    # Line of sight, batched.
    LosReq, los = api.method("horizon.v1.VisibilityService", "LineOfSight")
    req = LosReq(dataset="rainier")
    for i in range(5):
        line = req.lines.add()
        line.__getattribute__("from").CopyFrom(eye)
        line.to.CopyFrom(Point(frame=2, x=-121.74 + 0.01 * i, y=46.84, height=3000, height_mode=2))
    answer = los(req, timeout=10)
    assert len(answer.results) == 5 and all(r.distance > 0 for r in answer.results)

    # Culling.
    CullReq, cull = api.method("horizon.v1.VisibilityService", "CullBoxes")
    req = CullReq(dataset="rainier", observer=eye, conservative=True)
    for i in range(100):
        b = req.boxes.add(frame=2, x_min=-121.85 + 0.002 * i, x_max=-121.85 + 0.002 * i + 0.0005,
                          y_min=46.80, y_max=46.8005, z_min=0, z_max=1500 + 30 * i, id=5000 + i)
    req.boxes.add(frame=2, x_min=-100.0, x_max=-99.99, y_min=46.80, y_max=46.8005, z_min=0, z_max=10, id=1)
    culled = cull(req, timeout=10)
    assert len(culled.boxes) == 101 and culled.algorithm == "conservative"
    assert culled.visible_count == sum(b.visible for b in culled.boxes)
    assert 0 < culled.visible_count < 101, culled.visible_count
    assert [b.id for b in culled.boxes] == [5000 + i for i in range(100)] + [1]
    assert culled.out_of_range_count == 1
    # Each box's state, by its enum name: `visible` is false only for hidden boxes, the last is off the map.
    box_states = culled.boxes[0].DESCRIPTOR.fields_by_name["state"].enum_type.values_by_number
    names = [box_states[b.state].name for b in culled.boxes]
    assert names[100] == "BOX_STATE_OUT_OF_RANGE", names[100]
    for b, name in zip(culled.boxes[:100], names):
        assert name in ("BOX_STATE_VISIBLE", "BOX_STATE_HIDDEN", "BOX_STATE_UNDETERMINED"), name
        assert (name != "BOX_STATE_HIDDEN") == b.visible, (name, b.visible)

    # A camera trace: the header (eye, work, boxes with their ids), then the
    # depth rows in order; sky pixels are NaN.
    assert "horizon.v1.TraceService" in api.services, api.services
    TrReq, trace = api.method("horizon.v1.TraceService", "TraceCamera")
    req = TrReq(dataset="rainier", channels=[1], max_chunk_bytes=4096)  # TRACE_CHANNEL_DEPTH
    req.camera.position.CopyFrom(Point(frame=2, x=-121.90, y=46.70, height=800))
    req.camera.yaw, req.camera.pitch, req.camera.hfov, req.camera.width, req.camera.height = 40, -3, 60, 160, 90
    req.boxes.add(frame=2, x_min=-121.765, x_max=-121.755, y_min=46.848, y_max=46.856, z_min=4300, z_max=4500, id=77)
    header, depth = None, b""
    for m in trace(req, timeout=30):
        if m.WhichOneof("part") == "header":
            header = m.header
        else:
            assert m.rows.row0 * 160 * 4 == len(depth) and m.rows.channel == 1
            depth += m.rows.data
    assert header and (header.width, header.height) == (160, 90)
    assert abs(header.camera.elevation - header.camera.ground - 800) < 1e-6
    assert [b.id for b in header.boxes] == [77] and header.boxes[0].visible_pixels > 0
    values = struct.unpack("<%df" % (160 * 90), depth)
    assert sum(v != v for v in values) == header.stats.sky_pixels > 0  # NaN != NaN

    # Errors with details.
    def expect(call, request, code, field):
        try:
            result = call(request, timeout=10)
            if hasattr(result, "__iter__") and not hasattr(result, "ListFields"):
                list(result)
            raise AssertionError("expected %s" % code)
        except grpc.RpcError as e:
            got = api.details(e)
            assert got == (code, field) or (field is None and got[0] == code), (got, code, field, e.details())
    expect(get_dataset, GetReq(name="atlantis"), "NOT_FOUND", None)
    bad = VsReq(dataset="rainier", observer=Point(frame=2, x=-121.76, y=46.85, height=-3))
    expect(viewshed, bad, "INVALID_ARGUMENT", "observer.height")
    far = VsReq(dataset="rainier", observer=Point(frame=2, x=10, y=10, height=2))
    expect(viewshed, far, "OUT_OF_RANGE", "observer")
    inverted = CullReq(dataset="rainier", observer=eye)
    inverted.boxes.add(frame=2, x_min=-121.75, x_max=-121.76, y_min=46.8, y_max=46.81, z_min=0, z_max=1)
    expect(cull, inverted, "INVALID_ARGUMENT", "boxes[0].x_max")
    too_many = LosReq(dataset="rainier")
    for i in range(21):  # limits.max_lines is 20 in this config
        line = too_many.lines.add()
        line.__getattribute__("from").CopyFrom(eye)
        line.to.CopyFrom(Point(frame=2, x=-121.74, y=46.84, height=2))
    expect(los, too_many, "RESOURCE_EXHAUSTED", None)
    wide = TrReq()
    wide.CopyFrom(req)
    wide.camera.hfov = 175
    expect(trace, wide, "INVALID_ARGUMENT", "camera.hfov")
    # A deadline that passes mid-computation: the client sees DEADLINE_EXCEEDED
    # and the daemon stops the engine and logs the call with that status.
    slow = VsReq(dataset="rainier", observer=eye)
    slow.options.algorithm = 4  # ALGORITHM_R3 over the whole DEM: far longer than 20 ms
    try:
        list(viewshed(slow, timeout=0.02))
        raise AssertionError("expected DEADLINE_EXCEEDED")
    except grpc.RpcError as e:
        assert e.code() == grpc.StatusCode.DEADLINE_EXCEEDED, e.code()
    for _ in range(50):
        if '"status":"DEADLINE_EXCEEDED"' in open(log_path).read():
            break
        time.sleep(0.1)
    else:
        raise AssertionError("the daemon did not log the deadline")

    # A client cancelling mid-stream.
    request = VsReq(dataset="rainier", observer=eye, include_raster=True, max_chunk_bytes=4096)
    request.raster = 2  # float OHF: many chunks
    stream = viewshed(request, timeout=30)
    first = next(stream)
    assert first.WhichOneof("part") == "header"
    next(stream)
    stream.cancel()
    cancelled = False
    try:
        for _ in stream:
            pass
    except grpc.RpcError as e:
        cancelled = e.code() == grpc.StatusCode.CANCELLED
    assert cancelled or stream.code() == grpc.StatusCode.CANCELLED
    # (The daemon may have sent everything before the cancel arrived on these
    # small DEMs; the C++ test ServerRpc.ClientCancellingMidStreamEndsTheCall
    # checks the daemon's side on a raster too big to buffer.) It still serves:
    assert get_dataset(GetReq(name="olinda"), timeout=10).width == 111

    session_flight(api)

    # Prometheus metrics.
    metrics = urllib.request.urlopen("http://127.0.0.1:%d/metrics" % listening["metrics_port"], timeout=5).read().decode()
    for needle in ('horizon_requests_total{code="OK",method="CullBoxes"}', "horizon_request_duration_seconds_bucket",
                   "horizon_dataset_resident_bytes", "horizon_process_resident_bytes", 'code="NOT_FOUND"'):
        assert needle in metrics, needle


def session_flight(api):
    """A simulator's loop: open a clip-map session over Rainier with boxes, fly
    east sending a pose and reading its answer, keep the picture up to date
    from the changes, then add a box and close. The latest pose wins, so a
    client that sends faster than it reads gets the newest answered."""
    Request, Pose, SessionBox = (api.cls("horizon.v1." + n) for n in ("SessionRequest", "Pose", "SessionBox"))
    Response = api.cls("horizon.v1.SessionResponse")
    Point, Box = api.cls("horizon.v1.Point"), api.cls("horizon.v1.Box")
    session = api.channel.stream_stream("/horizon.v1.SessionService/Session",
                                        request_serializer=lambda x: x.SerializeToString(),
                                        response_deserializer=Response.FromString)

    def pose(i):  # absolute 3500 m, 250 m/s east
        return Pose(position=Point(frame=2, x=-121.86 + 0.004 * i, y=46.8529, height=3500, height_mode=2),
                    east_m_per_s=250, seq=i + 1)

    boxes = [SessionBox(id=100 + i, box=Box(frame=2, x_min=-121.9 + 0.01 * i, y_min=46.75, x_max=-121.898 + 0.01 * i,
                                            y_max=46.752, z_min=0, z_max=1500 + 60 * i)) for i in range(30)]
    q = queue.Queue()
    opening = Request()
    opening.open.dataset = "rainier"
    opening.open.clipmap.level_size = 64
    opening.open.clipmap.subtile = 16
    opening.open.mode = 2  # SESSION_MODE_CONSERVATIVE
    opening.open.first_pose.CopyFrom(pose(0))
    opening.open.boxes.extend(boxes)
    q.put(opening)

    def requests():
        while True:
            r = q.get()
            if r is None:
                return
            yield r

    replies = session(requests(), timeout=60, metadata=(("horizon-session-id", "py-flight"),))
    opened = next(replies)
    assert opened.WhichOneof("kind") == "opened", opened
    assert opened.opened.session_id == "py-flight" and opened.opened.clipmap.levels == 4, opened
    picture = {}
    first = next(replies)
    assert len(first.answer.changes) == 30, first
    for c in first.answer.changes:
        picture[c.id] = c.state
    for i in range(1, 20):
        q.put(Request(pose=pose(i)))
        r = next(replies)
        assert r.WhichOneof("kind") == "answer" and r.answer.seq == i + 1, r
        for c in r.answer.changes:
            picture[c.id] = c.state
        assert sum(1 for v in picture.values() if v == 1) == r.answer.visible  # BOX_STATE_VISIBLE
    delta = Request()
    delta.boxes.add.add(id=7, box=Box(frame=2, x_min=-121.76, y_min=46.85, x_max=-121.759, y_max=46.851, z_min=0,
                                      z_max=9000))
    q.put(delta)
    q.put(Request(pose=pose(20)))
    r = next(replies)
    seven = [c for c in r.answer.changes if c.id == 7]
    assert len(seven) == 1 and seven[0].state == 1 and r.answer.boxes == 31, r  # new, told, and 9 km up: visible
    q.put(None)  # close our side: the stream ends OK
    assert list(replies) == []
    assert replies.code() == grpc.StatusCode.OK


if __name__ == "__main__":
    main()
