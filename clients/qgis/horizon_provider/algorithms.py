"""Horizon's Processing algorithms: each runs the `horizon` CLI, on the DEM
layer's file (embedded) or, with a server, through a `horizond` daemon that
holds the same DEM as a dataset. Geometries are taken to the DEM's CRS; the
outputs are in it too.

- Horizon viewshed: a point and heights in, the GeoTIFF out (visible, the
  occlusion height field or the minimum visible target height), with the
  QGIS style (.qml) horizon writes beside it, so QGIS draws it at once.
- Cumulative viewshed: a point layer of observers in (heights and reaches
  from fields or defaults), the count (or any/all) GeoTIFF out.
- Line of sight: a line layer in (first vertex the eye, last the target),
  the same lines out with visible, distance, clearance and the first
  blocking point.
- Cull boxes: a viewpoint and a polygon layer of boxes (their bounding
  rectangles, z range from fields) in, the boxes out with their state.
"""
import csv
import json
import os
import shutil
import subprocess
import tempfile
import time

from qgis.core import (QgsCoordinateTransform, QgsFeature, QgsFeatureSink, QgsField, QgsFields, QgsGeometry,
                       QgsPointXY, QgsProcessing, QgsProcessingAlgorithm, QgsProcessingException,
                       QgsProcessingOutputNumber, QgsProcessingParameterDefinition, QgsProcessingParameterEnum,
                       QgsProcessingParameterFeatureSink, QgsProcessingParameterFeatureSource,
                       QgsProcessingParameterField, QgsProcessingParameterFileDestination,
                       QgsProcessingParameterNumber, QgsProcessingParameterPoint,
                       QgsProcessingParameterRasterDestination, QgsProcessingParameterRasterLayer,
                       QgsProcessingParameterString, QgsRectangle, QgsWkbTypes)
from qgis.PyQt.QtCore import QVariant

ALGORITHMS = ["fast", "exact", "conservative", "r3"]
OUTPUT_KINDS = ["visible", "ohf", "min-target-height"]
ACCUMULATIONS = ["count", "any", "all"]


def horizon_executable(configured):
    """The CLI: the parameter, else $HORIZON_CLI, else `horizon` on PATH."""
    for candidate in (configured, os.environ.get("HORIZON_CLI"), shutil.which("horizon")):
        if candidate:
            return candidate
    raise QgsProcessingException(
        "the horizon command-line tool was not found: give its path in the 'horizon CLI' parameter, set "
        "HORIZON_CLI, or put it on PATH")


class HorizonAlgorithm(QgsProcessingAlgorithm):
    """What every algorithm shares: the DEM, where horizon runs, how it is called."""

    DEM = "DEM"
    SERVER = "SERVER"
    DATASET = "DATASET"
    HORIZON = "HORIZON"
    OUTPUT = "OUTPUT"

    def group(self):
        return "Visibility"

    def groupId(self):  # noqa: N802
        return "visibility"

    def createInstance(self):  # noqa: N802
        return type(self)()

    def add_dem(self):
        self.addParameter(QgsProcessingParameterRasterLayer(self.DEM, "DEM (elevations, metres)"))

    def add_where(self):
        """The advanced parameters: a daemon, its dataset, the CLI's path."""
        for name, description in [
                (self.SERVER, "horizond daemon HOST:PORT (empty: run on the DEM's file)"),
                (self.DATASET, "Dataset name on the daemon (empty: the DEM file's name without extension)"),
                (self.HORIZON, "horizon CLI (empty: $HORIZON_CLI or horizon on PATH)")]:
            p = QgsProcessingParameterString(name, description, optional=True)
            p.setFlags(p.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
            self.addParameter(p)

    def dem_layer(self, parameters, context):
        layer = self.parameterAsRasterLayer(parameters, self.DEM, context)
        if layer is None:
            raise QgsProcessingException("DEM: not a raster layer")
        return layer

    def where(self, parameters, context, layer):
        """The CLI, the DEM operand (a file, or a dataset name) and the --server flags."""
        exe = horizon_executable(self.parameterAsString(parameters, self.HORIZON, context))
        server = self.parameterAsString(parameters, self.SERVER, context).strip()
        path = layer.source().split("|")[0]
        if not server:
            if not os.path.exists(path):
                raise QgsProcessingException("DEM: horizon reads files; '%s' is not one (or give a daemon)" % path)
            return exe, path, []
        dataset = self.parameterAsString(parameters, self.DATASET, context).strip()
        if not dataset:
            dataset = os.path.splitext(os.path.basename(path))[0]
        return exe, dataset, ["--server", server]

    def run_horizon(self, command, feedback):
        """Runs the CLI, relays what it says, stops it when the user cancels; its stdout (--json) parsed."""
        feedback.pushCommandInfo(" ".join(command))
        proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        while proc.poll() is None:
            if feedback.isCanceled():
                proc.terminate()
                proc.wait()
                raise QgsProcessingException("cancelled")
            time.sleep(0.05)
        out, err = proc.communicate()
        for line in err.splitlines():
            if line.strip():
                feedback.pushConsoleInfo(line)
        if proc.returncode != 0:
            message = next((l for l in err.splitlines() if "error:" in l), err.strip() or "failed")
            raise QgsProcessingException("horizon: %s (exit %d)" % (message.split("error:", 1)[-1].strip(),
                                                                    proc.returncode))
        try:
            return json.loads(out[out.index("{"):]) if "{" in out else {}
        except ValueError as e:
            raise QgsProcessingException("horizon printed no JSON summary: %s" % e)

    def transform_to(self, source, layer, context):
        return QgsCoordinateTransform(source.sourceCrs(), layer.crs(), context.transformContext())


def raster_path(path):
    """Processing may hand out a temporary name without .tif; horizon writes GeoTIFFs."""
    return path if path.lower().endswith((".tif", ".tiff")) else path + ".tif"


class Viewshed(HorizonAlgorithm):
    OBSERVER = "OBSERVER"
    HEIGHT = "HEIGHT"
    TARGET_HEIGHT = "TARGET_HEIGHT"
    MAX_DISTANCE = "MAX_DISTANCE"
    KIND = "OUTPUT_KIND"
    ALGORITHM = "ALGORITHM"
    PREVIEW = "PREVIEW"

    def name(self):
        return "viewshed"

    def displayName(self):  # noqa: N802
        return "Horizon viewshed"

    def shortHelpString(self):  # noqa: N802
        return ("What an observer sees over the DEM: a GeoTIFF of 1 visible, 0 hidden, 255 no answer (or the "
                "occlusion height field, or the height a target needs to be seen), styled at once. Runs horizon "
                "viewshed on the DEM's file, or on a horizond daemon's dataset.")

    def initAlgorithm(self, config=None):  # noqa: N802
        self.add_dem()
        self.addParameter(QgsProcessingParameterPoint(self.OBSERVER, "Observer"))
        self.addParameter(QgsProcessingParameterNumber(self.HEIGHT, "Eye height above the ground (m)",
                                                       QgsProcessingParameterNumber.Double, 2.0, minValue=0.0))
        self.addParameter(QgsProcessingParameterNumber(self.TARGET_HEIGHT, "Target height above the ground (m)",
                                                       QgsProcessingParameterNumber.Double, 0.0, minValue=0.0))
        self.addParameter(QgsProcessingParameterNumber(self.MAX_DISTANCE, "Max distance (m; 0: the whole DEM)",
                                                       QgsProcessingParameterNumber.Double, 0.0, minValue=0.0))
        self.addParameter(QgsProcessingParameterEnum(self.KIND, "Raster", options=OUTPUT_KINDS, defaultValue=0))
        self.addParameter(QgsProcessingParameterEnum(self.ALGORITHM, "Algorithm", options=ALGORITHMS,
                                                     defaultValue=0))
        self.add_where()
        self.addParameter(QgsProcessingParameterRasterDestination(self.OUTPUT, "Viewshed"))
        self.addParameter(QgsProcessingParameterFileDestination(self.PREVIEW, "Preview (PNG)", "PNG files (*.png)",
                                                                optional=True, createByDefault=False))
        self.addOutput(QgsProcessingOutputNumber("VISIBLE_CELLS", "Visible cells"))
        self.addOutput(QgsProcessingOutputNumber("VISIBLE_AREA_KM2", "Visible area (km2)"))

    def processAlgorithm(self, parameters, context, feedback):  # noqa: N802
        layer = self.dem_layer(parameters, context)
        exe, dem, server = self.where(parameters, context, layer)
        point = self.parameterAsPoint(parameters, self.OBSERVER, context, layer.crs())
        out = raster_path(self.parameterAsOutputLayer(parameters, self.OUTPUT, context))
        command = [exe, "viewshed", dem, "--observer", "%.10g,%.10g" % (point.x(), point.y()),
                   "--height", repr(self.parameterAsDouble(parameters, self.HEIGHT, context)),
                   "--target-height", repr(self.parameterAsDouble(parameters, self.TARGET_HEIGHT, context)),
                   "--output", OUTPUT_KINDS[self.parameterAsEnum(parameters, self.KIND, context)],
                   "--algorithm", ALGORITHMS[self.parameterAsEnum(parameters, self.ALGORITHM, context)],
                   "-o", out, "--json"] + server
        distance = self.parameterAsDouble(parameters, self.MAX_DISTANCE, context)
        if distance > 0:
            command += ["--max-distance", repr(distance)]
        preview = self.parameterAsFileOutput(parameters, self.PREVIEW, context)
        if preview:
            command += ["--png", preview]
        summary = self.run_horizon(command, feedback)
        feedback.pushInfo("%s visible cells (%.3f km2), style %s" % (
            summary.get("visible_cells"), summary.get("visible_area_km2", 0.0), os.path.splitext(out)[0] + ".qml"))
        return {self.OUTPUT: out, self.PREVIEW: preview or None, "VISIBLE_CELLS": summary.get("visible_cells"),
                "VISIBLE_AREA_KM2": summary.get("visible_area_km2")}


class CumulativeViewshed(HorizonAlgorithm):
    OBSERVERS = "OBSERVERS"
    HEIGHT = "HEIGHT"
    HEIGHT_FIELD = "HEIGHT_FIELD"
    MAX_DISTANCE = "MAX_DISTANCE"
    DISTANCE_FIELD = "DISTANCE_FIELD"
    TARGET_HEIGHT = "TARGET_HEIGHT"
    ACCUMULATE = "ACCUMULATE"
    ALGORITHM = "ALGORITHM"
    PREVIEW = "PREVIEW"

    def name(self):
        return "cumulativeviewshed"

    def displayName(self):  # noqa: N802
        return "Cumulative viewshed"

    def shortHelpString(self):  # noqa: N802
        return ("How many of the observers (points) see each cell: a UInt32 GeoTIFF (nodata 4294967295), or "
                "seen by any / by all of them (1/0/255), styled at once. Heights and reaches come from fields "
                "or the defaults.")

    def initAlgorithm(self, config=None):  # noqa: N802
        self.add_dem()
        self.addParameter(QgsProcessingParameterFeatureSource(self.OBSERVERS, "Observers",
                                                              [QgsProcessing.TypeVectorPoint]))
        self.addParameter(QgsProcessingParameterNumber(self.HEIGHT, "Eye height above the ground (m)",
                                                       QgsProcessingParameterNumber.Double, 2.0, minValue=0.0))
        self.addParameter(QgsProcessingParameterField(self.HEIGHT_FIELD, "Eye height field (m)", None,
                                                      self.OBSERVERS, QgsProcessingParameterField.Numeric,
                                                      optional=True))
        self.addParameter(QgsProcessingParameterNumber(self.MAX_DISTANCE, "Max distance (m)",
                                                       QgsProcessingParameterNumber.Double, 5000.0, minValue=1.0))
        self.addParameter(QgsProcessingParameterField(self.DISTANCE_FIELD, "Max distance field (m)", None,
                                                      self.OBSERVERS, QgsProcessingParameterField.Numeric,
                                                      optional=True))
        self.addParameter(QgsProcessingParameterNumber(self.TARGET_HEIGHT, "Target height above the ground (m)",
                                                       QgsProcessingParameterNumber.Double, 0.0, minValue=0.0))
        self.addParameter(QgsProcessingParameterEnum(self.ACCUMULATE, "Accumulate", options=ACCUMULATIONS,
                                                     defaultValue=0))
        self.addParameter(QgsProcessingParameterEnum(self.ALGORITHM, "Algorithm", options=ALGORITHMS,
                                                     defaultValue=0))
        self.add_where()
        self.addParameter(QgsProcessingParameterRasterDestination(self.OUTPUT, "Cumulative viewshed"))
        self.addParameter(QgsProcessingParameterFileDestination(self.PREVIEW, "Preview (PNG)", "PNG files (*.png)",
                                                                optional=True, createByDefault=False))
        self.addOutput(QgsProcessingOutputNumber("OBSERVER_COUNT", "Observers"))
        self.addOutput(QgsProcessingOutputNumber("MAX_COUNT", "Most observers seeing one cell"))

    def processAlgorithm(self, parameters, context, feedback):  # noqa: N802
        layer = self.dem_layer(parameters, context)
        exe, dem, server = self.where(parameters, context, layer)
        source = self.parameterAsSource(parameters, self.OBSERVERS, context)
        if source is None:
            raise QgsProcessingException("Observers: not a point layer")
        to_dem = self.transform_to(source, layer, context)
        height = self.parameterAsDouble(parameters, self.HEIGHT, context)
        distance = self.parameterAsDouble(parameters, self.MAX_DISTANCE, context)
        height_field = self.parameterAsString(parameters, self.HEIGHT_FIELD, context)
        distance_field = self.parameterAsString(parameters, self.DISTANCE_FIELD, context)
        out = raster_path(self.parameterAsOutputLayer(parameters, self.OUTPUT, context))
        with tempfile.TemporaryDirectory(prefix="horizon-qgis-") as tmp:
            sites = os.path.join(tmp, "observers.csv")
            count = 0
            with open(sites, "w", newline="") as f:
                w = csv.writer(f)  # x,y,height,max_distance in the DEM's CRS (no header)
                for feature in source.getFeatures():
                    geometry = feature.geometry()
                    if geometry.isEmpty():
                        continue
                    geometry.transform(to_dem)
                    h = feature[height_field] if height_field else height
                    d = feature[distance_field] if distance_field else distance
                    for p in geometry.asMultiPoint() if geometry.isMultipart() else [geometry.asPoint()]:
                        w.writerow(["%.10g" % p.x(), "%.10g" % p.y(), repr(float(h if h is not None else height)),
                                    repr(float(d if d else distance))])
                        count += 1
            if count == 0:
                raise QgsProcessingException("Observers: the layer has no points")
            command = [exe, "viewshed", dem, "--observers", sites,
                       "--accumulate", ACCUMULATIONS[self.parameterAsEnum(parameters, self.ACCUMULATE, context)],
                       "--target-height", repr(self.parameterAsDouble(parameters, self.TARGET_HEIGHT, context)),
                       "--algorithm", ALGORITHMS[self.parameterAsEnum(parameters, self.ALGORITHM, context)],
                       "-o", out, "--json"] + server
            preview = self.parameterAsFileOutput(parameters, self.PREVIEW, context)
            if preview:
                command += ["--png", preview]
            summary = self.run_horizon(command, feedback)
        return {self.OUTPUT: out, self.PREVIEW: preview or None, "OBSERVER_COUNT": count,
                "MAX_COUNT": summary.get("max_count")}


class LineOfSight(HorizonAlgorithm):
    LINES = "LINES"
    FROM_HEIGHT = "FROM_HEIGHT"
    TO_HEIGHT = "TO_HEIGHT"

    def name(self):
        return "lineofsight"

    def displayName(self):  # noqa: N802
        return "Line of sight"

    def shortHelpString(self):  # noqa: N802
        return ("Tests each line (its first vertex the eye, its last the target) by the exact R3 rule: the "
                "lines come back with visible (1/0), their ground distance, the clearance (the sight line's least "
                "height above the terrain, metres) and the first point where the terrain blocks it.")

    def initAlgorithm(self, config=None):  # noqa: N802
        self.add_dem()
        self.addParameter(QgsProcessingParameterFeatureSource(self.LINES, "Sight lines",
                                                              [QgsProcessing.TypeVectorLine]))
        self.addParameter(QgsProcessingParameterNumber(self.FROM_HEIGHT, "Eye height above the ground (m)",
                                                       QgsProcessingParameterNumber.Double, 2.0, minValue=0.0))
        self.addParameter(QgsProcessingParameterNumber(self.TO_HEIGHT, "Target height above the ground (m)",
                                                       QgsProcessingParameterNumber.Double, 0.0, minValue=0.0))
        self.add_where()
        self.addParameter(QgsProcessingParameterFeatureSink(self.OUTPUT, "Lines of sight",
                                                            QgsProcessing.TypeVectorLine))

    def processAlgorithm(self, parameters, context, feedback):  # noqa: N802
        layer = self.dem_layer(parameters, context)
        exe, dem, server = self.where(parameters, context, layer)
        source = self.parameterAsSource(parameters, self.LINES, context)
        if source is None:
            raise QgsProcessingException("Sight lines: not a line layer")
        fields = QgsFields(source.fields())
        for name, kind in [("visible", QVariant.Int), ("distance_m", QVariant.Double),
                           ("clearance_m", QVariant.Double), ("block_x", QVariant.Double),
                           ("block_y", QVariant.Double), ("block_dist_m", QVariant.Double)]:
            fields.append(QgsField(name, kind))
        sink, dest = self.parameterAsSink(parameters, self.OUTPUT, context, fields, QgsWkbTypes.LineString,
                                          layer.crs())
        to_dem = self.transform_to(source, layer, context)
        heights = ["--from-height", repr(self.parameterAsDouble(parameters, self.FROM_HEIGHT, context)),
                   "--to-height", repr(self.parameterAsDouble(parameters, self.TO_HEIGHT, context))]
        total = max(1, source.featureCount())
        for i, feature in enumerate(source.getFeatures()):
            if feedback.isCanceled():
                break
            geometry = feature.geometry()
            if geometry.isEmpty():
                continue
            geometry.transform(to_dem)
            vertices = [QgsPointXY(v) for v in geometry.vertices()]
            a, b = vertices[0], vertices[-1]
            j = self.run_horizon([exe, "los", dem, "--from", "%.10g,%.10g" % (a.x(), a.y()),
                                  "--to", "%.10g,%.10g" % (b.x(), b.y()), "--json"] + heights + server, feedback)
            block = j.get("first_block") or {}
            out = QgsFeature(fields)
            out.setGeometry(QgsGeometry.fromPolylineXY([a, b]))
            clearance = j.get("clearance")
            out.setAttributes(feature.attributes() + [
                1 if j.get("visible") else 0, j.get("distance"),
                clearance if isinstance(clearance, (int, float)) else None,
                block.get("x"), block.get("y"), block.get("distance")])
            sink.addFeature(out, QgsFeatureSink.FastInsert)
            feedback.setProgress(100.0 * (i + 1) / total)
        return {self.OUTPUT: dest}


class CullBoxes(HorizonAlgorithm):
    OBSERVER = "OBSERVER"
    HEIGHT = "HEIGHT"
    BOXES = "BOXES"
    Z_MIN_FIELD = "Z_MIN_FIELD"
    Z_MAX_FIELD = "Z_MAX_FIELD"
    CONSERVATIVE = "CONSERVATIVE"

    def name(self):
        return "cullboxes"

    def displayName(self):  # noqa: N802
        return "Cull boxes"

    def shortHelpString(self):  # noqa: N802
        return ("Which object boxes (each polygon's bounding rectangle, from z_min to z_max absolute metres) the "
                "observer can see: the boxes come back with state (visible, hidden, undetermined over a void, "
                "out_of_range), visible (1/0) and ohf_min, the lowest visible elevation over the box.")

    def initAlgorithm(self, config=None):  # noqa: N802
        self.add_dem()
        self.addParameter(QgsProcessingParameterPoint(self.OBSERVER, "Observer"))
        self.addParameter(QgsProcessingParameterNumber(self.HEIGHT, "Eye height above the ground (m)",
                                                       QgsProcessingParameterNumber.Double, 2.0, minValue=0.0))
        self.addParameter(QgsProcessingParameterFeatureSource(self.BOXES, "Boxes",
                                                              [QgsProcessing.TypeVectorPolygon]))
        # Optional only so that a call may leave them out: z_min and z_max then.
        self.addParameter(QgsProcessingParameterField(self.Z_MIN_FIELD, "Bottom field (absolute m)", "z_min",
                                                      self.BOXES, QgsProcessingParameterField.Numeric, optional=True))
        self.addParameter(QgsProcessingParameterField(self.Z_MAX_FIELD, "Top field (absolute m)", "z_max",
                                                      self.BOXES, QgsProcessingParameterField.Numeric, optional=True))
        self.addParameter(QgsProcessingParameterEnum(self.CONSERVATIVE, "Algorithm",
                                                     options=["fast", "conservative (never hides a seen box)"],
                                                     defaultValue=0))
        self.add_where()
        self.addParameter(QgsProcessingParameterFeatureSink(self.OUTPUT, "Culled boxes",
                                                            QgsProcessing.TypeVectorPolygon))

    def processAlgorithm(self, parameters, context, feedback):  # noqa: N802
        layer = self.dem_layer(parameters, context)
        exe, dem, server = self.where(parameters, context, layer)
        point = self.parameterAsPoint(parameters, self.OBSERVER, context, layer.crs())
        source = self.parameterAsSource(parameters, self.BOXES, context)
        if source is None:
            raise QgsProcessingException("Boxes: not a polygon layer")
        z_min = self.parameterAsString(parameters, self.Z_MIN_FIELD, context) or "z_min"
        z_max = self.parameterAsString(parameters, self.Z_MAX_FIELD, context) or "z_max"
        for field in (z_min, z_max):
            if source.fields().indexOf(field) < 0:
                raise QgsProcessingException("Boxes: no field '%s' (the boxes' bottom and top, absolute metres)" % field)
        to_dem = self.transform_to(source, layer, context)
        fields = QgsFields(source.fields())
        for name, kind in [("state", QVariant.String), ("visible", QVariant.Int), ("ohf_min", QVariant.Double)]:
            fields.append(QgsField(name, kind))
        sink, dest = self.parameterAsSink(parameters, self.OUTPUT, context, fields, QgsWkbTypes.Polygon, layer.crs())
        boxes = []  # (feature, rectangle in the DEM's CRS)
        with tempfile.TemporaryDirectory(prefix="horizon-qgis-") as tmp:
            path = os.path.join(tmp, "boxes.csv")
            with open(path, "w", newline="") as f:
                w = csv.writer(f)
                for feature in source.getFeatures():
                    geometry = feature.geometry()
                    if geometry.isEmpty() or feature[z_min] is None or feature[z_max] is None:
                        continue
                    geometry.transform(to_dem)
                    r = geometry.boundingBox()
                    w.writerow(["%.10g" % v for v in (r.xMinimum(), r.yMinimum(), r.xMaximum(), r.yMaximum(),
                                                       float(feature[z_min]), float(feature[z_max]))])
                    boxes.append((feature, QgsRectangle(r)))
            if not boxes:
                raise QgsProcessingException("Boxes: no polygon with both z fields set")
            command = [exe, "cull", dem, "--observer", "%.10g,%.10g" % (point.x(), point.y()),
                       "--height", repr(self.parameterAsDouble(parameters, self.HEIGHT, context)),
                       "--boxes", path, "--json"] + server
            if self.parameterAsEnum(parameters, self.CONSERVATIVE, context) == 1:
                command.append("--conservative")
            summary = self.run_horizon(command, feedback)
        answers = summary.get("boxes", [])
        if len(answers) != len(boxes):
            raise QgsProcessingException("horizon answered %d boxes of %d" % (len(answers), len(boxes)))
        for (feature, rect), answer in zip(boxes, answers):
            out = QgsFeature(fields)
            out.setGeometry(QgsGeometry.fromRect(rect))
            ohf_min = answer.get("ohf_min")
            out.setAttributes(feature.attributes() + [answer.get("state"), 1 if answer.get("visible") else 0,
                                                      ohf_min if isinstance(ohf_min, (int, float)) else None])
            sink.addFeature(out, QgsFeatureSink.FastInsert)
        return {self.OUTPUT: dest}
