"""The reproduction's figures, each drawn as a task of its pool (the main process never
draws): the design's evidence and each experiment's responses."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from twolink.simulation.sim import Trajectory


def design_figures(result: Any, out: Path) -> list[Any]:
    """The design's evidence (a worker task): phase plane with centres, membership
    functions, the control surfaces of the heuristic, the paper's and the designed rule
    base, and the cluster-validity sweep, which it returns
    (:func:`twolink.studies.designs.validity.validity_sweep`: c = 2..10, PC, PE, XB)."""
    from twolink.controllers import fuzzy
    from twolink.figures import plots
    from twolink.studies.designs.validity import validity_figure, validity_sweep

    validity = validity_sweep(result.points, result.weights)

    designed_engine = result.engine.with_rules(result.rules)
    plots.save_figure(plots.phase_plane_figure(result), out / "figures/design_phase_plane.png")
    plots.save_figure(plots.membership_figure(result.engine), out / "figures/membership.png")
    plots.save_figure(
        plots.control_surface_figure(
            {
                "7x7 heuristic": result.engine,
                "paper Table 1": fuzzy.paper_fuzzy_pd(),
                "FCM-designed": designed_engine,
            }
        ),
        out / "figures/control_surfaces.png",
    )
    plots.save_figure(
        validity_figure(validity, result.clustering.n_clusters),
        out / "figures/design_validity.png",
    )
    return validity


def response_figure(out: Path, runs: dict[str, str], joint: int, title: str, path: Path) -> None:
    """One experiment's response under each controller, read from its run folders (a
    worker task)."""
    from twolink.figures import plots

    trajs = {
        name: Trajectory.load(out / folder / "trajectory.npz") for name, folder in runs.items()
    }
    plots.save_figure(plots.response_figure(trajs, joint, title), path)
