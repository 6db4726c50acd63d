"""Words per sentence over a Markdown page's prose: the docs' readability measure.

Run ``python tests/readability.py [PAGE ...]`` for a table (page, sentences, median, p90);
with no page it measures README.md and every docs/*.md. It exits 1 when a page is over the
limits. tests/test_readability.py runs the same measure in the default suite.

What counts as prose:

- Skipped: fenced code blocks, table rows (lines starting ``|``), headings (``#``), HTML
  comments, image lines and lines that hold only links.
- A paragraph is a run of prose lines up to a blank line or a list item.
- Each list item is its own paragraph: its last sentence ends where the item ends, with or
  without a full stop. A block quote's ``>`` is dropped and its text is prose.
- A bold label that opens a paragraph or an item and ends in ``.`` or ``:`` (``**Noise.**``)
  is a heading in the text: it is dropped, not counted as a sentence.

How sentences are split: a sentence ends at ``.``, ``?`` or ``!`` (and any closing quote,
bracket or ``*``) followed by a space and a word that does not start in lower case. The
end of a paragraph ends a sentence too. So "e.g. a", "0.5 s", "Fig. 3" and "vs. CTC" do not
split: the first three because a lower-case word or no space follows, the others by the
list ``ABBREVIATIONS``. ``;`` and ``:`` do not end a sentence.

What counts as a word: a whitespace-separated token with a letter or a digit in it. An
inline code span is one word; a link counts its text, not its address.

The median is the middle value; the 90th percentile interpolates linearly between ranks
(numpy's default).
"""

from __future__ import annotations

import re
import statistics
import sys
from dataclasses import dataclass
from pathlib import Path

MEDIAN_LIMIT = 22
P90_LIMIT = 45
ABBREVIATIONS = {"e.g", "i.e", "fig", "figs", "eq", "eqs", "vs", "cf", "no", "ref", "sec", "al"}

_FENCE = re.compile(r"^\s*(```|~~~)")
_LIST_ITEM = re.compile(r"^\s*([-*+]|\d+[.)])\s+")
_IMAGE_LINE = re.compile(r"^\s*!\[[^\]]*\]\([^)]*\)\s*$")
_LINK = re.compile(r"!?\[([^\]]*)\]\([^)]*\)")
_LINKS_ONLY = re.compile(r"^\s*(\[[^\]]*\]\([^)]*\)[\s,;·|—-]*)+$")
_CODE_SPAN = re.compile(r"(`+)(.+?)\1")
_END = re.compile(r"""(?<=[.?!])(["'”’)\]*_]*)\s+(?=[^\sa-z])""")
_WORD = re.compile(r"[^\W_]")
_LABEL = re.compile(r"^\*\*[^*]+[.:]\*\*\s*")


def paragraphs(text: str) -> list[str]:
    """The page's prose, one string per paragraph or list item, markup kept."""
    text = re.sub(r"<!--.*?-->", "", text, flags=re.S)
    out: list[str] = []
    current: list[str] = []
    fenced = False

    def close() -> None:
        if current:
            out.append(" ".join(current))
            current.clear()

    for line in text.splitlines():
        if _FENCE.match(line):
            close()
            fenced = not fenced
            continue
        if fenced:
            continue
        stripped = line.strip()
        if stripped.startswith(">"):
            stripped = stripped.lstrip("> ").strip()
        if (
            not stripped
            or stripped.startswith("|")
            or stripped.startswith("#")
            or _IMAGE_LINE.match(stripped)
            or _LINKS_ONLY.match(stripped)
        ):
            close()
            continue
        if _LIST_ITEM.match(stripped):
            close()
            stripped = _LIST_ITEM.sub("", stripped, count=1)
        if not current:
            stripped = _LABEL.sub("", stripped)
        current.append(stripped)
    close()
    return out


def sentences(paragraph: str) -> list[str]:
    """A paragraph's sentences (see the module's docstring for the rule)."""
    codes: list[str] = []

    def hide(match: re.Match) -> str:
        codes.append(match.group(0))
        return f"CODE{len(codes) - 1}x"

    plain = _CODE_SPAN.sub(hide, paragraph)  # a "." inside code does not end a sentence
    plain = _LINK.sub(r"\1", plain)
    out: list[str] = []
    start = 0
    for match in _END.finditer(plain):
        sentence = plain[start : match.end(1)]
        before = sentence.split()
        last = before[-1].rstrip(".?!\"'”’)]*_").lower().lstrip("(\"'“‘*_") if before else ""
        if last in ABBREVIATIONS:
            continue
        out.append(sentence.strip())
        start = match.end()
    out.append(plain[start:].strip())
    return [s for s in out if words(s)]


def words(sentence: str) -> int:
    """Tokens with a letter or digit in them (an inline code span was made one token)."""
    return sum(1 for token in sentence.split() if _WORD.search(token))


def percentile(values: list[int], q: float) -> float:
    """Linear interpolation between closest ranks (numpy.percentile's default)."""
    ordered = sorted(values)
    pos = (len(ordered) - 1) * q / 100
    low = int(pos)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (pos - low)


@dataclass(frozen=True)
class Measure:
    page: str
    sentences: int
    median: float
    p90: float

    @property
    def ok(self) -> bool:
        return self.median <= MEDIAN_LIMIT and self.p90 <= P90_LIMIT


def lengths(text: str) -> list[int]:
    """Words per sentence, over every sentence of the page's prose."""
    return [words(s) for p in paragraphs(text) for s in sentences(p)]


def measure(path: Path, name: str | None = None) -> Measure:
    counts = lengths(path.read_text(encoding="utf-8")) or [0]
    return Measure(
        name or str(path), len(counts), statistics.median(counts), percentile(counts, 90)
    )


def pages(root: Path) -> list[Path]:
    """The pages the limits hold for: README.md and every docs/*.md."""
    return [root / "README.md", *sorted((root / "docs").glob("*.md"))]


def main(argv: list[str]) -> int:
    root = Path(__file__).resolve().parents[1]
    paths = [Path(a) for a in argv] or pages(root)
    rows = [measure(p, str(p.relative_to(root)) if p.is_relative_to(root) else str(p))
            for p in paths]  # fmt: skip
    print(f"| page | sentences | median | p90 | within {MEDIAN_LIMIT} / {P90_LIMIT} |")
    print("|---|---:|---:|---:|---|")
    for r in rows:
        print(f"| {r.page} | {r.sentences} | {r.median:g} | {r.p90:.1f} | "
              f"{'yes' if r.ok else 'no'} |")  # fmt: skip
    return 0 if all(r.ok for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
