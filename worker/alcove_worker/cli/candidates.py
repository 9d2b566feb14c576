"""`alcove campaign candidates CAMPAIGN_ID ITERATION`: an iteration's candidate scenarios, ranked,
with which were picked and why. Reads
:func:`alcove.campaigns.views.picks.iteration_candidates`, the function behind
``GET /campaigns/{id}/iterations/{k}/candidates``; ``--json`` prints that route's JSON."""

from __future__ import annotations

from typing import Any

import typer

from alcove.ids import MAX_ID
from alcove_worker.cli.follow import fail


def read_candidates(campaign_id: int, iteration: int) -> Any:
    """The API's :class:`IterationCandidates` of iteration ``iteration``; a campaign or an
    iteration that does not exist exits 2 naming the argument."""
    from alcove.campaigns.views import picks
    from alcove.db import open_transaction
    from alcove.errors import NotFound

    try:
        with open_transaction() as s:
            return picks.iteration_candidates(s, campaign_id, iteration)
    except NotFound as exc:
        fail("iteration" if exc.what == "iteration" else "campaign_id", exc.message)


def _num(x: float | None, digits: int = 4) -> str:
    return "–" if x is None else f"{x:.{digits}g}"


def _scenario(scenario: dict[str, Any] | None) -> str:
    values = (scenario or {}).get("values") or {}
    if not values:
        return "the task as written"
    return "\n".join(f"{k} = {v:.4g}" for k, v in values.items())


def candidates_table(data: Any) -> Any:
    """A Rich table of the candidates ranked (unscored ones last, by slot)."""
    from rich.table import Table

    t = Table(
        title=f"iteration {data.iteration_index}: strategy {data.strategy}, q = {data.batch}, C = {data.n_candidates}"
        + (f", min distance {data.min_distance:.3g}" if data.min_distance is not None else "")
        + (f", stopping threshold {data.min_disagreement:.3g} N" if data.min_disagreement is not None else "")
    )
    for name, just in (
        ("slot", "right"),
        ("scenario", "left"),
        ("score [N]", "right"),
        ("rank", "right"),
        ("picked", "right"),
        ("code", "left"),
    ):
        t.add_column(name, justify=just, no_wrap=True)  # type: ignore[arg-type]
    t.add_column("reason", overflow="fold")
    ranked = sorted(data.candidates, key=lambda c: (c.rank if c.rank is not None else 10**9, c.slot))
    for c in ranked:
        t.add_row(
            str(c.slot),
            _scenario(c.scenario),
            _num(c.score),
            "–" if c.rank is None else str(c.rank),
            "–" if c.pick is None else str(c.pick + 1),
            c.why.code,
            c.why.text,
        )
    return t


def candidates(
    campaign_id: int = typer.Argument(..., min=1, max=MAX_ID, help="campaign id"),
    iteration: int = typer.Argument(..., min=1, max=MAX_ID, help="iteration index k (1 = the first acquisition)"),
    as_json: bool = typer.Option(False, "--json", help="print the API's JSON (GET .../iterations/{k}/candidates)"),
) -> None:
    """An iteration's candidates and why each was or was not picked.

    A table ranked by score: slot (the candidate's ocp slot), its scenario values, score (the
    ensemble's disagreement over its contact phase [N]), rank (1 = highest), picked (pick order,
    1 = first), code (picked-top, picked-far, replayed, too-close, batch-full, no-contact,
    below-threshold, not-converged, pending) and reason (the same with the figures). The rows
    are those of GET /campaigns/{id}/iterations/{k}/candidates, which --json prints as is.
    Strategy paper has no candidates. A campaign or an iteration that does not exist: an error
    naming campaign_id or iteration, exit code 2."""
    from rich.console import Console

    data = read_candidates(campaign_id, iteration)
    if as_json:
        typer.echo(data.model_dump_json())
        return
    if not data.candidates:
        typer.echo(
            f"iteration {iteration} has no candidates"
            + (
                " (strategy paper solves the task as written, one trajectory per iteration)"
                if data.strategy == "paper"
                else " yet"
            )
        )
        return
    Console(width=max(Console().width, 140)).print(candidates_table(data))


__all__ = ["candidates", "candidates_table", "read_candidates"]
