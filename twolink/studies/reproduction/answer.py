"""The reproduction's answer at a glance: its claims studies as :class:`Judged` regimes,
summary.md, and the answer and profile figures (a task of the pool: the main process never
draws). The text is :mod:`twolink.studies.reproduction.summary`'s, the drawing
:mod:`twolink.figures.answer`'s, the profiles :mod:`twolink.studies.reproduction.profiles`'."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from twolink.simulation.vocabulary import CLAIMED_BETTER, metric
from twolink.studies.designs.effort import EFFORT_KEYS
from twolink.studies.reproduction.manifest import Manifest
from twolink.studies.reproduction.summary import (
    ANSWER_FIGURE,
    PROFILES_FIGURE,
    SCOREBOARD_FIGURE,
    Judged,
    summary,
)

__all__ = ["answer_figures", "judged", "question", "write_summary"]


# the regimes' short names in the answer and what they mean, by their files' suffix
REGIME_NAMES = {
    "": ("quintic moves", "the claims study's 2 s moves"),
    "_raw": ("raw steps", "the paper's own steps at ωn = 3 rad/s"),
    "_lab": ("lab arm", "quintic moves with joint friction and a load step"),
}


def judged(manifest: Manifest, studies: Sequence[Any]) -> list[Judged]:
    """Each claims study (:class:`twolink.studies.judgments.conclusions.ClaimsStudy`, in
    :func:`twolink.studies.judgments.claims_studies.run_claims`' order: the claims sweep,
    each raw-steps variant, the lab arm) with its files: ``claims[_V].csv`` against the baseline,
    ``claims_matched[_V].csv`` against the other opponent, ``claims_tuned[_V].csv`` against
    each tuned law, ``claims_study[_V]/``; and its ``ranking.csv`` rows."""
    suffixes = ["", *(f"_{v.name}" for v in manifest.variants if v.raw_steps)]
    suffixes += ["_lab"] * sum(bool(getattr(s, "lab", False)) for s in studies)  # the lab arm
    out = []
    for study, suffix in zip(studies, suffixes, strict=True):
        files = {
            name: (f"claims{'' if name == study.baseline else '_matched'}{suffix}.csv", t)
            for name, t in study.claims.items()
        }
        tuned = getattr(study, "tuned", {})  # the tuned laws' rows (claims_tuned*.csv)
        files |= {name: (f"claims_tuned{suffix}.csv", t) for name, t in tuned.items()}
        name, defined = REGIME_NAMES.get(suffix, ("", ""))
        sweep = f"claims_study{suffix}"
        effort = {o: _effort_rows(study.every, study.proposed, o) for o in study.claims}
        out.append(
            Judged(study.label, study.plants, study.proposed, files, sweep, name, defined,
                   effort={o: t for o, t in effort.items() if len(t)},
                   ranking=getattr(study, "ranking", None))
        )  # fmt: skip
    return out


def _effort_rows(every: Any, proposed: str, opponent: str) -> Any:
    """The pair's peak |τ| and Σ|Δτ| rows of the study's every-pair table (empty: none)."""
    mine = (every["proposed"] == proposed) & (every["opponent"] == opponent)
    return every[mine & every["metric"].isin(EFFORT_KEYS)]


def with_iae(out: Path, studies: Sequence[Judged]) -> list[Judged]:
    """Each regime with its controllers' median IAE1 + IAE2 over its plants, from its
    sweep's ``results.parquet`` (the scoreboard's order and the strongest opponent)."""
    from dataclasses import replace

    from twolink.studies.reproduction.profiles import scoreboard
    from twolink.sweep import load_results

    done = []
    for s in studies:
        board = scoreboard(load_results(out / s.sweep))
        iae = board.drop_duplicates("controller").set_index("controller")["iae_sum"]
        done.append(replace(s, iae=iae.to_dict()))
    return done


def question(manifest: Manifest) -> str:
    symbols = ", ".join(metric(k).symbol for k in CLAIMED_BETTER)
    return f"the paper's step metrics ({symbols}, on each joint)"


# the report's first section ends here: the rest of summary.md is a pointer away
POINTER = "**Terms, the verdicts counted, and where the numbers come from:** `summary.md`."


def write_summary(out: Path, manifest: Manifest, studies: Sequence[Judged]) -> list[str]:
    """summary.md in ``out``; returns its lines for the report's first section: the
    question, the answer and the figures, then :data:`POINTER` (the first table then
    comes early)."""
    from twolink.foundation.io import atomic_write_text
    from twolink.studies.designs.frontier import OPPONENT

    what = {
        manifest.baseline: "the paper's baseline",
        OPPONENT: f"CTC tuned per joint by search within {manifest.proposed}'s effort, on its "
        "training plants and on these (docs/reproduction.md; its rows include the effort)",
    }
    names = dict.fromkeys(n for s in studies for n in s.tables)
    tuned = {n for s in studies for n, (f, _) in s.tables.items() if f.startswith("claims_tuned")}
    from twolink.studies.designs.searched_opponent import TUNED

    what |= {n: f"{TUNED.get(n, n)}, tuned by CTC-best's rule" for n in tuned}
    opponents = {n: what.get(n, "an opponent of the manifest") for n in names}
    text = summary(studies, opponents, question(manifest))
    atomic_write_text(out / "summary.md", text)
    lines = text.splitlines()
    terms = next(k for k, s in enumerate(lines) if s.startswith("**Terms.**"))
    return [*lines[:terms], POINTER]


def answer_figures(out: Path, studies: Sequence[Judged], proposed: str) -> None:
    """figures/answer.png (the claims tables as a forest plot), figures/scoreboard.png
    (every controller's medians per regime) and figures/profiles.png (each sweep's
    performance profiles on IAE and Σ|Δτ|), a worker task."""
    from twolink.figures import answer, plots
    from twolink.figures.scoreboard import scoreboard_figure
    from twolink.studies.reproduction.profiles import (
        PROFILE_COSTS,
        costs,
        performance_profile,
        scoreboard,
    )
    from twolink.sweep import load_results

    plants = ", ".join(sorted({str(s.plants) for s in studies}))
    title = f"Does {proposed} lower the paper's step metrics? {plants} plants per panel"
    # the forest plot: the baseline and CTC-best (the tuned laws are the scoreboard's; six
    # opponents a panel would hide each other's verdicts)
    tables = [
        (s.label, {n: t for n, (f, t) in s.tables.items() if not f.startswith("claims_tuned")})
        for s in studies
    ]
    plots.save_figure(answer.answer_figure(tables, proposed, title), out / ANSWER_FIGURE)
    boards = [(s.name or s.label, scoreboard(load_results(out / s.sweep))) for s in studies]
    over = {
        s.name or s.label: set(s.ranking.loc[~s.ranking["within"].astype(bool), "controller"])
        for s in studies
        if s.ranking is not None
    }
    title = f"Every controller of the claims studies, {plants} plants per regime"
    plots.save_figure(scoreboard_figure(boards, title, over), out / SCOREBOARD_FIGURE)
    profiles = []
    for s in studies:
        results = load_results(out / s.sweep)
        for key in PROFILE_COSTS:
            m = metric(key)
            label = f"{s.label}:\n{m.label} (θ1 + θ2)"
            profiles.append((label, performance_profile(costs(results, key))))
    plots.save_figure(answer.profiles_figure(profiles), out / PROFILES_FIGURE)


def answer_at_a_glance(
    out: Path, manifest: Manifest, claim_tables: Sequence[Any], draw: Any
) -> list[str]:
    """The answer at a glance: its figures drawn by ``draw`` (a task of the pool), and
    ``summary.md`` written; returns the summary's lines (the report's first section)."""
    studies = with_iae(out, judged(manifest, claim_tables))
    draw(answer_figures, out, studies, manifest.proposed)
    return write_summary(out, manifest, studies)
