"""Times on a moving reference judged by their distance to the move's own
(docs/metrics.md, "Times on a moving reference"): the claims tables' rule that a time
shorter than the move's is lag, not speed."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

__all__ = ["TIMES_OF_THE_MOVE", "move_distances"]

# Times a moving reference has itself (claims_plans.reference_values): on such a move a
# loop is judged by how far its time lies from the move's own, either way. Tr, a length
# of time, is judged with Td beside it (move_distances): a pure lag moves Td, not Tr.
TIMES_OF_THE_MOVE = (
    "delay_time_s",
    "rise_time_s",
    "peak_time_s",
    "settling_time_s",
    "settling_time_target_s",
)


def move_distances(
    values: Mapping[tuple[int, str], np.ndarray], own: Mapping[tuple[int, str], float]
) -> dict[tuple[int, str], np.ndarray]:
    """The times of :data:`TIMES_OF_THE_MOVE` on a move with its own (``own`` > 0) as the
    distances the claims judge (docs/metrics.md: shorter than the move's is lag, not
    speed): |T − T_ref| for Td, Tp, Ts and Ts→θd; for Tr, the distance of the rise to the
    move's own, |Td − Td_ref| + |Tr − Tr_ref| / 2 (the farther end of a rise window
    centred on Td: a pure lag L gives L, a rise longer by s with the same centre s/2).
    ``values``: (joint, metric) -> the controllers' values (any shape, the same for all);
    the other entries are returned as they are. Tr needs Td of its joint and its own."""
    out = dict(values)
    for (j, key), v in values.items():
        ref = own.get((j, key), math.nan)
        if key not in TIMES_OF_THE_MOVE or not ref > 0:  # a step's own times are 0
            continue
        out[(j, key)] = np.abs(v - ref)
        if key == "rise_time_s":
            td, td_own = values.get((j, "delay_time_s")), own.get((j, "delay_time_s"), math.nan)
            if td is None or not td_own > 0:
                raise ValueError(
                    f"θ{j} Tr on a moving reference is judged with Td beside it: "
                    f"joint{j}_delay_time_s and the move's own Td are needed"
                )
            out[(j, key)] = np.abs(td - td_own) + out[(j, key)] / 2.0
    return out
