"""Identification (objective, optimisers, uncertainty) and prediction: calls the model, never io."""

from taptune.identify.core import Identification, IdentifyOptions, Prediction, identify, predict
from taptune.identify.objective import ObjectiveOptions
from taptune.identify.optimize import Cancelled, GAOptions

__all__ = [
    "Cancelled",
    "GAOptions",
    "Identification",
    "IdentifyOptions",
    "ObjectiveOptions",
    "Prediction",
    "identify",
    "predict",
]
