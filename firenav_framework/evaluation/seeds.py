"""The held-out protocol: named seed sets for choosing defaults and for reporting them.

A default (a noise level, a threshold, a particle count) is chosen on the ``tuning``
seeds only; the figures that go into the README and the method documents come from
the ``report`` seeds, which no default was chosen on, with at least 20 runs a row.
Whoever looked at report figures and then changed a default must move to the
``fresh-report`` seeds and say so (docs/scale-out.md, "The held-out protocol").

Seeds are given as a name (``tuning``), a count ``N`` (seeds 0..N-1, as before; at
most :data:`MAX_COUNT`), a range ``A-B`` (inclusive) or a comma-separated list whose
items are seeds, ranges or names (``report,5,7-9``). A bare count above
:data:`MAX_COUNT` is refused: ``1000`` reads as a thousand runs from seed 0, almost
always meant as seed 1000 (``1000-1000``) or a range.
"""
from __future__ import annotations

#: name -> seeds. Tuning and report sets never overlap.
SEED_SETS: dict[str, range] = {
    "tuning": range(100, 140),
    "report": range(1000, 1030),
    "fresh-report": range(2000, 2030),
}


#: Largest bare count ``N`` accepted; more runs are given as a range ``0-N``.
MAX_COUNT = 100


class SeedError(ValueError):
    """A seed expression that cannot be read."""


def _item(text: str) -> list[int]:
    text = text.strip()
    if text in SEED_SETS:
        return list(SEED_SETS[text])
    if "-" in text.lstrip("-"):
        a, b = text.split("-", 1)
        lo, hi = int(a), int(b)
        if hi < lo:
            raise SeedError(f"range '{text}' ends before it starts")
        return list(range(lo, hi + 1))
    return [int(text)]


def _count(text: str) -> int:
    n = int(text)
    if n > MAX_COUNT:
        raise SeedError(f"a bare count means seeds 0..{n - 1}, and counts above {MAX_COUNT} "
                        f"are refused: give a range ({n}-{n} for seed {n} alone, "
                        f"0-{n - 1} for {n} runs from seed 0)")
    return n


def parse_seeds(text: str) -> list[int]:
    """``"5"`` -> 0..4 (counts up to :data:`MAX_COUNT`); ``"3-7"`` -> 3..7; ``"tuning"`` -> 100..139; ``"1,4,9"`` -> those.

    Raises :class:`SeedError` naming the expression and the accepted forms.
    """
    forms = f"give N, A-B, a list or a name ({', '.join(SEED_SETS)})"
    try:
        text = str(text).strip()
        if "," in text:
            seeds = [s for part in text.split(",") if part.strip() for s in _item(part)]
        elif text in SEED_SETS or "-" in text.lstrip("-"):
            seeds = _item(text)
        else:
            seeds = list(range(_count(text)))
    except SeedError as exc:
        raise SeedError(f"seeds '{text}': {exc}; {forms}") from None
    except ValueError:
        raise SeedError(f"seeds '{text}': {forms}") from None
    if not seeds or min(seeds) < 0:
        raise SeedError(f"seeds '{text}': need at least one seed, all >= 0")
    if len(set(seeds)) != len(seeds):
        raise SeedError(f"seeds '{text}': a seed appears twice")
    return seeds


def seed_set_name(seeds: list[int | None]) -> str | None:
    """The name of the seed set ``seeds`` is exactly, or lies inside; None if neither."""
    given = set(seeds)
    for name, seed_range in SEED_SETS.items():
        if given and given <= set(seed_range):
            return name if len(given) == len(seed_range) else f"part of {name}"
    return None


def describe_seeds(seeds: list[int | None]) -> str:
    """``[1000, ..., 1029]`` -> ``"1000-1029 (report)"`` for summaries and reports."""
    if seeds == [None]:
        return "recorded data (one run)"
    ints = sorted(s for s in seeds if s is not None)
    if ints and ints == list(range(ints[0], ints[-1] + 1)) and len(ints) > 2:
        text = f"{ints[0]}-{ints[-1]}"
    else:
        text = ", ".join(str(s) for s in ints)
    name = seed_set_name(ints)
    return f"{text} ({name})" if name else text
