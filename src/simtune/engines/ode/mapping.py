"""How simtune's parameters become ODE settings: read by the engine's world and by its export alike.

ODE has no default time step (``dWorldStep`` takes one per call) and no default
surface (every contact's parameters come from the near callback): simtune's generic
values are here.  ODE leaves combining two touching surfaces to the near callback:
simtune takes the geometric mean of the two material groups' values.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from simtune.tasks.spec import CONTACT_GROUPS, MATERIALS

#: simtune's generic time step [s]
DEFAULT_TIMESTEP = 0.005
#: the generic surface: Coulomb friction 1, no bounce, no rolling friction
DEFAULT_CONTACT = {"lateral_friction": 1.0, "rolling_friction": 0.0, "spinning_friction": 0.0, "restitution": 0.0}
BOUNCE_VELOCITY = 0.01  # [m/s] slower impacts do not bounce (keeps resting contacts quiet)

#: the group parameters ODE maps: surfaces of every contact group, damping of the moving bodies
GROUP_PARAMETERS = frozenset(
    {f"{kind}_{g}" for kind in DEFAULT_CONTACT for g in CONTACT_GROUPS}
    | {f"{kind}_{g}" for kind in ("linear_damping", "angular_damping") for g in ("gripper", *MATERIALS)}
)


class PairSurface(NamedTuple):
    """The surface of a contact between two material groups (ODE's ``dSurfaceParameters`` values)."""

    mu: float  # Coulomb friction (ODE's pyramid approximation: a coefficient)
    rolling: float  # rolling friction about the tangent axes (rho, rho2)
    spinning: float  # rolling friction about the normal (rhoN)
    bounce: float  # restitution


def pair_surface(values: dict[str, float], a: str, b: str) -> PairSurface:
    """The surface of contacts between groups ``a`` and ``b``: each value the geometric mean of the two groups'
    (a group without a value in ``values`` has the generic one)."""

    def mean(kind: str) -> float:
        default = DEFAULT_CONTACT[kind]
        return float(np.sqrt(values.get(f"{kind}_{a}", default) * values.get(f"{kind}_{b}", default)))

    return PairSurface(
        mean("lateral_friction"), mean("rolling_friction"), mean("spinning_friction"), mean("restitution")
    )
