"""Parameter spaces (the seed paper's Table I and our extension) and their validation."""

from simtune.params.space import (
    PARAMETERS,
    SPACES,
    Parameter,
    ParameterSpace,
    find_parameter,
    get_space,
    read_params_file,
    validate_params,
)

__all__ = [
    "PARAMETERS",
    "SPACES",
    "Parameter",
    "ParameterSpace",
    "find_parameter",
    "get_space",
    "read_params_file",
    "validate_params",
]
