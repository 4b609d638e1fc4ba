#!/usr/bin/env python3
"""The QGIS Processing provider (clients/qgis/horizon_provider) run headless
in PyQGIS (Debian's python3-qgis, QT_QPA_PLATFORM=offscreen) on the bundled
DEMs: each algorithm through processing.run, embedded and against a real
horizond, and its output layers checked as QGIS reads them: CRS, extent,
nodata, the style QGIS loads from the .qml beside the GeoTIFF, and values
(against the horizon CLI's own answers). Exit 77 (ctest: skipped) when
PyQGIS is not installed.
"""
import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

try:
    from qgis.core import (QgsApplication, QgsCoordinateReferenceSystem, QgsFeature, QgsField, QgsGeometry,
                           QgsPointXY, QgsRasterLayer, QgsRectangle, QgsVectorLayer)
    from qgis.PyQt.QtCore import QVariant
except ImportError as e:
    print("skipped: PyQGIS is not installed (%s); scripts/setup.sh installs python3-qgis" % e)
    sys.exit(77)

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
RAINIER = "rainier_summit_srtm3_400x400.tif"
EYE = (-121.6767, 46.75)  # a ridge facing Rainier's south flank


def values(path):
    """The raster as QGIS's provider reads it: (array, layer)."""
    layer = QgsRasterLayer(path, "out")
    assert layer.isValid(), path
    p = layer.dataProvider()
    block = p.block(1, p.extent(), p.xSize(), p.ySize())
    dtype = {1: np.uint8, 4: np.uint32, 6: np.float32}[int(p.dataType(1))]  # Qgis.Byte, UInt32, Float32
    return np.frombuffer(bytes(block.data()), dtype=dtype).reshape(p.ySize(), p.xSize()), layer


def check_raster_layer(path, dem, renderer, nodata):
    array, layer = values(path)
    assert layer.crs().authid() == dem.crs().authid(), (layer.crs().authid(), dem.crs().authid())
    assert dem.extent().contains(layer.extent()), (layer.extent().toString(), dem.extent().toString())
    assert abs(layer.rasterUnitsPerPixelX() - dem.rasterUnitsPerPixelX()) < 1e-12
    p = layer.dataProvider()
    assert p.sourceHasNoDataValue(1) and (np.isnan(nodata) and np.isnan(p.sourceNoDataValue(1))
                                          or p.sourceNoDataValue(1) == nodata), p.sourceNoDataValue(1)
    # QGIS drew it with the style horizon wrote beside it (OUT.qml), not a grey stretch.
    assert os.path.exists(os.path.splitext(path)[0] + ".qml")
    assert layer.renderer().type() == renderer, layer.renderer().type()
    return array, layer


def run_cli(horizon, *args):
    out = subprocess.run([horizon] + list(args), capture_output=True, text=True, check=True).stdout
    return json.loads(out[out.index("{"):])


def start_daemon(horizond, data_dir, tmp):
    config = os.path.join(tmp, "horizond.json")
    with open(config, "w") as f:
        json.dump({"listen": "127.0.0.1:0", "plaintext": True, "data_root": data_dir,
                   "datasets": {"rainier": RAINIER}, "memory_budget_mb": 256, "scratch_dir": tmp,
                   "gpu": {"contexts": 0}}, f)
    log_path = os.path.join(tmp, "horizond.log")
    with open(log_path, "w") as log:
        proc = subprocess.Popen([horizond, "--config", config], stderr=log)
    for _ in range(500):
        with open(log_path) as f:
            text = f.read()
        if '"datasets_loaded"' in text:
            break
        time.sleep(0.02)
    listening = json.loads(next(l for l in text.splitlines() if '"listening"' in l))
    return proc, "127.0.0.1:%d" % listening["grpc_port"]


def memory_layer(kind, crs, fields, rows):
    layer = QgsVectorLayer("%s?crs=%s" % (kind, crs), "input", "memory")
    p = layer.dataProvider()
    p.addAttributes([QgsField(name, t) for name, t in fields])
    layer.updateFields()
    features = []
    for geometry, attributes in rows:
        f = QgsFeature(layer.fields())
        f.setGeometry(geometry)
        f.setAttributes(attributes)
        features.append(f)
    p.addFeatures(features)
    return layer


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--horizon", required=True)
    parser.add_argument("--horizond", required=True)
    parser.add_argument("--data-dir", required=True)
    parser.add_argument("--provider-dir", default=os.path.join(HERE, "..", "..", "clients", "qgis"))
    args = parser.parse_args()
    os.environ["HORIZON_CLI"] = args.horizon
    started = time.time()

    sys.path.append(os.path.join(QgsApplication.pkgDataPath(), "python", "plugins"))
    sys.path.insert(0, os.path.abspath(args.provider_dir))
    import processing
    from processing.core.Processing import Processing
    from horizon_provider.provider import HorizonProvider
    Processing.initialize()
    provider = HorizonProvider()
    assert QgsApplication.processingRegistry().addProvider(provider)
    names = sorted(a.displayName() for a in provider.algorithms())
    assert names == ["Cull boxes", "Cumulative viewshed", "Horizon viewshed", "Line of sight"], names

    dem_path = os.path.join(args.data_dir, RAINIER)
    dem = QgsRasterLayer(dem_path, "rainier")
    assert dem.isValid()
    eye = "%r,%r [EPSG:4326]" % EYE
    checks = 0
    with tempfile.TemporaryDirectory(prefix="horizon-qgis-test-") as tmp:
        # Viewshed, visible/hidden: paletted, 1/0/255, the CLI's counts, the preview beside it.
        out = os.path.join(tmp, "viewshed.tif")
        result = processing.run("horizon:viewshed", {
            "DEM": dem, "OBSERVER": eye, "HEIGHT": 2, "MAX_DISTANCE": 15000, "OUTPUT_KIND": 0, "OUTPUT": out,
            "PREVIEW": os.path.join(tmp, "viewshed.png")})
        array, layer = check_raster_layer(result["OUTPUT"], dem, "paletted", 255)
        classes = {c.value: c.color.name() for c in layer.renderer().classes()}
        assert classes == {0.0: "#d55e00", 1.0: "#0072b2"}, classes
        assert set(np.unique(array)) <= {0, 1, 255}
        cli = run_cli(args.horizon, "viewshed", dem_path, "--lat", str(EYE[1]), "--lon", str(EYE[0]),
                      "--max-distance", "15000", "-o", os.path.join(tmp, "cli.tif"), "--json")
        assert int((array == 1).sum()) == cli["visible_cells"] == result["VISIBLE_CELLS"] > 1000, \
            ((array == 1).sum(), cli["visible_cells"], result["VISIBLE_CELLS"])
        assert abs(layer.extent().width() / dem.rasterUnitsPerPixelX() - cli["window"]["width"]) < 1e-6
        assert os.path.getsize(os.path.join(tmp, "viewshed.png")) > 10000
        checks += 1

        # The same observer given in another CRS (web Mercator) is taken to the DEM's: the same answer.
        from qgis.core import QgsCoordinateTransform, QgsProject
        to_3857 = QgsCoordinateTransform(QgsCoordinateReferenceSystem("EPSG:4326"),
                                         QgsCoordinateReferenceSystem("EPSG:3857"), QgsProject.instance())
        p = to_3857.transform(QgsPointXY(*EYE))
        again = processing.run("horizon:viewshed", {
            "DEM": dem, "OBSERVER": "%r,%r [EPSG:3857]" % (p.x(), p.y()), "MAX_DISTANCE": 15000,
            "OUTPUT": os.path.join(tmp, "viewshed_3857.tif")})
        assert again["VISIBLE_CELLS"] == result["VISIBLE_CELLS"], (again["VISIBLE_CELLS"], result["VISIBLE_CELLS"])
        checks += 1

        # The occlusion height field and the minimum target height: ramps, float32, NaN-free answers.
        for kind, name in [(1, "ohf"), (2, "mth")]:
            r = processing.run("horizon:viewshed", {"DEM": dem, "OBSERVER": eye, "MAX_DISTANCE": 8000,
                                                    "OUTPUT_KIND": kind, "OUTPUT": os.path.join(tmp, name + ".tif")})
            array, layer = check_raster_layer(r["OUTPUT"], dem, "singlebandpseudocolor", -32768)
            answered = array[array != -32768]
            assert answered.size > 1000 and np.isfinite(answered).all()
            shader = layer.renderer().shader().rasterShaderFunction()
            items = shader.colorRampItemList()
            if name == "ohf":
                assert abs(items[0].value - answered.min()) < 1e-3 and abs(items[-1].value - answered.max()) < 1e-3
            else:
                assert items[0].value == 0 and items[0].color.name() == "#0072b2" and answered.min() == 0
                assert items[-1].value >= answered.max()
            checks += 1

        # Cumulative viewshed: three observers (one with its own height and reach), counted.
        towers = memory_layer("Point", "EPSG:4326", [("h", QVariant.Double), ("reach", QVariant.Double)], [
            (QgsGeometry.fromPointXY(QgsPointXY(-121.6767, 46.75)), [10.0, 8000.0]),
            (QgsGeometry.fromPointXY(QgsPointXY(-121.7322, 46.8357)), [5.0, 6000.0]),
            (QgsGeometry.fromPointXY(QgsPointXY(-121.80, 46.80)), [20.0, None])])
        r = processing.run("horizon:cumulativeviewshed", {
            "DEM": dem, "OBSERVERS": towers, "HEIGHT_FIELD": "h", "DISTANCE_FIELD": "reach", "MAX_DISTANCE": 5000,
            "OUTPUT": os.path.join(tmp, "count.tif"), "PREVIEW": os.path.join(tmp, "count.png")})
        array, layer = check_raster_layer(r["OUTPUT"], dem, "singlebandpseudocolor", 4294967295)
        counted = array[array != 4294967295]
        assert r["OBSERVER_COUNT"] == 3 and counted.max() == r["MAX_COUNT"] >= 1, (r, counted.max())
        csv_path = os.path.join(tmp, "towers.csv")
        with open(csv_path, "w") as f:
            f.write("lon,lat,height,max_distance\n-121.6767,46.75,10,8000\n-121.7322,46.8357,5,6000\n"
                    "-121.8,46.8,20,5000\n")
        cli = run_cli(args.horizon, "viewshed", dem_path, "--observers", csv_path, "-o",
                      os.path.join(tmp, "count_cli.tif"), "--json")
        assert int((counted > 0).sum()) == cli["cells_seen_by_any"], ((counted > 0).sum(), cli["cells_seen_by_any"])
        checks += 1

        # Line of sight: lines in EPSG:4326, answered in the DEM's CRS with the CLI's answers.
        pairs = [((-121.6767, 46.75), (-121.7604, 46.8529)), ((-121.6767, 46.75), (-121.70, 46.76)),
                 ((-121.80, 46.80), (-121.6767, 46.75))]
        lines = memory_layer("LineString", "EPSG:4326", [("name", QVariant.String)], [
            (QgsGeometry.fromPolylineXY([QgsPointXY(*a), QgsPointXY(*b)]), ["line %d" % i])
            for i, (a, b) in enumerate(pairs)])
        r = processing.run("horizon:lineofsight", {"DEM": dem, "LINES": lines, "OUTPUT": "memory:"})
        out = r["OUTPUT"]
        assert out.crs().authid() == "EPSG:4326" and out.featureCount() == 3
        for f, (a, b) in zip(out.getFeatures(), pairs):
            cli = run_cli(args.horizon, "los", dem_path, "--from", "%r,%r" % a, "--to", "%r,%r" % b, "--json")
            assert f["visible"] == (1 if cli["visible"] else 0), (f["name"], f["visible"], cli["visible"])
            assert abs(f["distance_m"] - cli["distance"]) < 1e-6
            assert isinstance(f["block_x"], float) == (cli.get("first_block") is not None), (f["block_x"], cli)
        assert {f["visible"] for f in out.getFeatures()} == {0, 1}, "the lines were chosen to be both"
        checks += 1

        # Cull boxes: polygons in web Mercator with their z range, answered per box.
        boxes = []
        for lon0, lat0, lon1, lat1, z0, z1 in [(-121.7330, 46.8352, -121.7314, 46.8362, 3040, 3090),
                                               (-121.7620, 46.8520, -121.7590, 46.8540, 4340, 4400),
                                               (-121.8000, 46.8000, -121.7980, 46.8020, 1640, 1680)]:
            a, b = to_3857.transform(QgsPointXY(lon0, lat0)), to_3857.transform(QgsPointXY(lon1, lat1))
            boxes.append((QgsGeometry.fromRect(QgsRectangle(a, b)), [float(z0), float(z1)]))
        box_layer = memory_layer("Polygon", "EPSG:3857", [("z_min", QVariant.Double), ("z_max", QVariant.Double)],
                                 boxes)
        r = processing.run("horizon:cullboxes", {"DEM": dem, "OBSERVER": "-121.7604,46.8529 [EPSG:4326]",
                                                 "BOXES": box_layer, "OUTPUT": "memory:"})
        out = r["OUTPUT"]
        states = [f["state"] for f in out.getFeatures()]
        assert out.crs().authid() == "EPSG:4326" and len(states) == 3, states
        assert set(states) <= {"visible", "hidden", "undetermined", "out_of_range"} and "visible" in states, states
        checks += 1

        # Against a running daemon: the same answers through --server.
        proc, address = start_daemon(args.horizond, os.path.abspath(args.data_dir), tmp)
        try:
            where = {"SERVER": address, "DATASET": "rainier"}
            remote = processing.run("horizon:viewshed", dict(where, DEM=dem, OBSERVER=eye, MAX_DISTANCE=15000,
                                                             OUTPUT=os.path.join(tmp, "remote.tif")))
            remote_array, _ = check_raster_layer(remote["OUTPUT"], dem, "paletted", 255)
            local_array, _ = values(result["OUTPUT"])
            assert np.array_equal(remote_array, local_array)
            r = processing.run("horizon:lineofsight", dict(where, DEM=dem, LINES=lines, OUTPUT="memory:"))
            assert [f["visible"] for f in r["OUTPUT"].getFeatures()] == [f["visible"] for f in out_los(
                processing, dem, lines)]
            r = processing.run("horizon:cullboxes", dict(where, DEM=dem, OBSERVER="-121.7604,46.8529 [EPSG:4326]",
                                                         BOXES=box_layer, OUTPUT="memory:"))
            assert [f["state"] for f in r["OUTPUT"].getFeatures()] == states
            r = processing.run("horizon:cumulativeviewshed", dict(
                where, DEM=dem, OBSERVERS=towers, HEIGHT_FIELD="h", DISTANCE_FIELD="reach", MAX_DISTANCE=5000,
                OUTPUT=os.path.join(tmp, "remote_count.tif")))
            remote_counts, _ = values(r["OUTPUT"])
            local_counts, _ = values(os.path.join(tmp, "count.tif"))
            assert np.array_equal(remote_counts, local_counts)
            # A daemon error comes back as the algorithm's error, naming what was wrong.
            try:
                processing.run("horizon:viewshed", dict(where, DATASET="nope", DEM=dem, OBSERVER=eye,
                                                        OUTPUT=os.path.join(tmp, "nope.tif")))
                raise AssertionError("an unknown dataset must fail")
            except Exception as e:  # QgsProcessingException
                assert "nope" in str(e), e
            checks += 1
        finally:
            proc.send_signal(signal.SIGTERM)
            proc.wait(timeout=30)
    print("ok: QGIS provider, %d checks in %.1f s" % (checks, time.time() - started))
    return 0


def out_los(processing, dem, lines):
    return processing.run("horizon:lineofsight", {"DEM": dem, "LINES": lines, "OUTPUT": "memory:"})["OUTPUT"] \
        .getFeatures()


if __name__ == "__main__":
    app = QgsApplication([], False)
    app.initQgis()
    code = main()
    # PyQGIS 3.22 crashes tearing down the Processing framework (exitQgis, or
    # the interpreter's own exit, with its Python providers registered): the
    # checks are done and reported, so leave without the teardown.
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
