"""Parameter files of CONTRACT §1: one definition per parameter, validation, presets."""

from pencli.params.definitions import BY_KEY, KINDS, PARAMETERS, RULES, Param, params_of
from pencli.params.validate import ParameterSet, validate_mapping

__all__ = ["BY_KEY", "KINDS", "PARAMETERS", "RULES", "Param", "ParameterSet", "params_of", "validate_mapping"]
