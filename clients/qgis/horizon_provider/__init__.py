"""Horizon for QGIS: a Processing provider whose algorithms run the `horizon`
command-line tool (embedded, on a DEM file) or ask a `horizond` daemon
(--server), with layers in and layers out.

Install: copy or link this folder into QGIS's python/plugins directory (it is
a plugin), or, from PyQGIS:

    from horizon_provider.provider import HorizonProvider
    QgsApplication.processingRegistry().addProvider(HorizonProvider())
"""


def classFactory(iface):  # noqa: N802 (QGIS's name)
    from .plugin import HorizonPlugin
    return HorizonPlugin(iface)
