"""dlo_env: a pymunk cord on a table, as goal-conditioned Gymnasium environments.

Importing the package registers ``dlo_env/DLOEndpoint-v0`` and ``dlo_env/DLODualEndpoint-v0``,
and their learned twins ``dlo_env/DLOEndpointSurrogate-v0`` and
``dlo_env/DLODualEndpointSurrogate-v0`` (which need torch; ``gym.make_vec(...,
vectorization_mode="vector_entry_point")`` steps a whole batch in one call). Gymnasium 1.x
ignores entry-point plugins, so registration happens here.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from dlo_env import goals, randomize
from dlo_env.cord import Cord, CordParams
from dlo_env.errors import InputError
from dlo_env.shapes import (
    COSINE_THRESHOLD,
    TABLE_HALF,
    bead_share,
    direction_free_error,
    error,
    is_cord_like,
    max_error,
    random_cord_shape,
    validate_shape,
    wavy_cord_shape,
    wide_cord_shape,
)

__all__ = [
    "COSINE_THRESHOLD",
    "SURROGATE_OF",
    "TABLE_HALF",
    "Cord",
    "CordParams",
    "InputError",
    "bead_share",
    "direction_free_error",
    "error",
    "goals",
    "is_cord_like",
    "max_error",
    "random_cord_shape",
    "randomize",
    "validate_shape",
    "wavy_cord_shape",
    "wide_cord_shape",
]

_ENVS = {
    "dlo_env/DLOEndpoint-v0": "dlo_env.envs.endpoint:DLOEndpointEnv",
    "dlo_env/DLODualEndpoint-v0": "dlo_env.envs.dual_endpoint:DLODualEndpointEnv",
}
for _id, _entry in _ENVS.items():
    if _id not in registry:
        register(id=_id, entry_point=_entry, max_episode_steps=100)
#: Each pymunk environment's learned twin (same spaces, reward and options).
SURROGATE_OF = {
    "dlo_env/DLOEndpoint-v0": "dlo_env/DLOEndpointSurrogate-v0",
    "dlo_env/DLODualEndpoint-v0": "dlo_env/DLODualEndpointSurrogate-v0",
}
for _id in SURROGATE_OF.values():
    _name = _id.split("/")[1].split("-")[0]
    if _id not in registry:
        register(id=_id, entry_point=f"dlo_env.envs.surrogate:{_name}Env",
                 vector_entry_point=f"dlo_env.envs.surrogate:{_name}VectorEnv",
                 max_episode_steps=100)
