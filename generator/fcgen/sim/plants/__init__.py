"""Plants fcgen did not write (CommonRoad's vehicle models), the mapping between their states and fcgen's, and the
actuation and sensing between controller and plant (latency, steering lag, measurement noise): docs/plants.md."""

from .spec import (
    DEFAULT_NOISE,
    PLANT_KINDS,
    PLANT_PARAMS,
    PREDICTIONS,
    PlantSpec,
    parse_noise,
    plant_from_meta,
    plant_of,
)

__all__ = [
    "DEFAULT_NOISE",
    "PLANT_KINDS",
    "PLANT_PARAMS",
    "PREDICTIONS",
    "PlantSpec",
    "parse_noise",
    "plant_from_meta",
    "plant_of",
]
