"""The docs read at a user's pace: short sentences (tests/readability.py measures them) and
no history (what changed when goes to CHANGELOG.md, not the manual)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from readability import MEDIAN_LIMIT, P90_LIMIT, lengths, measure, pages, paragraphs, sentences

ROOT = Path(__file__).resolve().parents[1]


def split(text: str) -> list[str]:
    return [s for p in paragraphs(text) for s in sentences(p)]


def test_sentences_end_at_a_stop_a_question_or_an_exclamation():
    assert split("One two. Three four? Five six! Seven") == [
        "One two.",
        "Three four?",
        "Five six!",
        "Seven",
    ]
    quoted = ['He said "stop."', "Then (it ran.)", "Next"]
    assert split(" ".join(quoted)) == quoted


def test_abbreviations_decimals_and_lower_case_do_not_end_a_sentence():
    text = "Gains e.g. Kp, i.e. one, Fig. 3 and vs. CTC at 0.5 s. and so on. End"
    assert split(text) == [text[:-4], "End"]
    assert split("a; b: c") == ["a; b: c"]  # ";" and ":" do not split


def test_code_tables_headings_comments_images_and_link_lines_are_not_prose():
    text = "\n".join(
        [
            "# A heading. With stops.",
            "```python",
            "x = 1. Then more. Code",
            "```",
            "| a. B | c. D |",
            "<!-- a comment. Over",
            "two lines. -->",
            "![a figure. Caption](figures/a.png)",
            "[one](a.md) · [two](b.md)",
            "Only this.",
        ]
    )
    assert split(text) == ["Only this."]


def test_list_items_and_paragraphs_end_their_sentences_and_labels_are_dropped():
    text = "- first item\n  goes on\n- **Label.** second item. Two\n\nA para\nacross lines"
    assert split(text) == ["first item goes on", "second item.", "Two", "A para across lines"]


def test_words_count_a_code_span_as_one_and_a_link_by_its_text():
    assert lengths("Run `twolink reproduce --no-trace. Now` and see [the page](a/b.md). Done") == [
        6,
        1,
    ]
    assert lengths("A — dash = 3 words") == [4]  # tokens without a letter or digit are not words


def test_the_median_and_the_90th_percentile(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(" ".join(f"W {'w ' * (n - 1)}end." for n in range(1, 11)))  # 2 .. 11 words
    m = measure(page)
    assert (m.sentences, m.median, m.p90) == (10, 6.5, pytest.approx(10.1))
    assert m.ok is True


@pytest.mark.parametrize("page", pages(ROOT), ids=lambda p: str(p.relative_to(ROOT)))
def test_each_page_is_within_the_limits(page):
    m = measure(page)
    assert m.median <= MEDIAN_LIMIT and m.p90 <= P90_LIMIT, m


# What history looks like in a manual. Each pattern is narrow enough to miss the manual's
# own words: "issue" only before a number, a hash only as 7-12 hex digits with a letter and
# a digit (a rule base's 16-digit digest is a content address, not a commit), a date only in
# full ISO form.
HISTORY = {
    "an issue number": r"\bissues? #?\d+|(?<![\w&/#])#\d+\b(?!-)",
    "a commit": r"\bcommits? [0-9a-f]{7}|\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,12}\b",
    "a date": r"\b20\d\d-\d\d-\d\d\b|\bmeasured (on |in )?20\d\d\b",
    "a was/before aside": r"\((was|formerly|previously|before)\b[ ,:]",
}


def history(text: str) -> list[str]:
    found = []
    for n, line in enumerate(text.splitlines(), 1):
        for what, pattern in HISTORY.items():
            if re.search(pattern, line, re.IGNORECASE):
                found.append(f"{n}: {what}: {line.strip()[:100]}")
    return found


def test_the_history_patterns_catch_history_and_miss_the_manual():
    caught = [
        "fixed in issue 48",
        "see #49 for why",
        "since commit 94c22a7",
        "the hash e4e7cf9 changed",
        "measured 2026-11-29",
        "measured in 2026 on the VM",
        "a ValueError (was RecursionError)",
        "the batch (before, a batch took its own)",
    ]
    missed = [
        "CTC no longer linearises the arm",
        "a rule base's digest 1bd7d00f8b349e9a",
        "resolution 4.7936899621426287e-05",
        "an issue a user may hit",
        "Tables 2-8 of the paper",
        "the key is used to seed the draws",
        "see [the section](#1-the-plant)",
        "deadbee is a word",
    ]
    assert [t for t in caught if not history(t)] == []
    assert [t for t in missed if history(t)] == []


@pytest.mark.parametrize("page", sorted((ROOT / "docs").glob("*.md")), ids=lambda p: p.name)
def test_the_manual_has_no_history(page):
    assert history(page.read_text(encoding="utf-8")) == []
