"""The package's warning class.

Degenerate but legal input (a gate so wide it accepts everything, a Monte-Carlo
run too short for its own confidence interval, ...) is reported with
:class:`RadarFusionWarning`, so readers can filter or escalate exactly the
package's warnings::

    import warnings
    from radarfusion_ref.engine.errors import RadarFusionWarning
    warnings.simplefilter("error", RadarFusionWarning)
"""

__all__ = ["RadarFusionWarning"]


class RadarFusionWarning(UserWarning):
    """Degenerate but legal input to a :mod:`radarfusion_ref` function."""
