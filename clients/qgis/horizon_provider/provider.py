"""The Processing provider: "Horizon" with its four algorithms."""
from qgis.core import QgsProcessingProvider

from .algorithms import CullBoxes, CumulativeViewshed, LineOfSight, Viewshed


class HorizonProvider(QgsProcessingProvider):
    def id(self):
        return "horizon"

    def name(self):
        return "Horizon"

    def longName(self):  # noqa: N802
        return "Horizon terrain visibility"

    def loadAlgorithms(self):  # noqa: N802
        for algorithm in (Viewshed(), CumulativeViewshed(), LineOfSight(), CullBoxes()):
            self.addAlgorithm(algorithm)
