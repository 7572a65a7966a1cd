# Source tags of scenario values: where a number comes from, read from the file's comments.
"""Source tags of a scenario file's values (``[paper]``, ``[reconstructed: ...]``, ...).

The built-in scenarios say where every value comes from in a bracketed tag at
the end of its comment (analyses/README.md), e.g.::

    kappa_per_s2 = 0.5   # κ [1/s²] [reconstructed: spec §2.3 example]

TOML parsers drop comments, so :func:`source_tags` reads them from the text:
for each ``key = value  # comment`` line (and each ``[table]`` header: the
table's tag) it takes the last bracketed group of the comment whose text
starts with a source word (:data:`SOURCE_WORDS`: paper, patent, seed,
recalled, reconstructed, trainctl, spec, ...) or names a page (``p.299``);
unit brackets such as ``[1/s²]`` or ``[steps]`` are skipped. The
keys are file key paths as scenario errors and :meth:`Scenario.replace
<trainctl.scenario.Scenario.replace>` spell them (``"controller.kappa_per_s2"``,
``"train.vehicle[2].mass_t"``, 0-based array-of-tables indices). A value
written over several lines (a multi-line array) is tagged by its first line's
comment. The report shows the tags beside the settings.
"""

from __future__ import annotations

import re

__all__ = ["SOURCE_WORDS", "source_tags"]

SOURCE_WORDS = ("paper", "patent", "seed", "recalled", "reconstructed", "trainctl", "spec",
                "book", "source", "computed", "measured", "assumed")
"""First words that make a bracketed comment group a source tag (case-insensitive)."""

_TABLE = re.compile(r"^\s*\[\s*([A-Za-z0-9_.\- \"]+?)\s*\]\s*(#.*)?$")
_ARRAY_TABLE = re.compile(r"^\s*\[\[\s*([A-Za-z0-9_.\- \"]+?)\s*\]\]\s*(#.*)?$")
_KEY = re.compile(r"^\s*([A-Za-z0-9_\-]+(?:\s*\.\s*[A-Za-z0-9_\-]+)*)\s*=")
_GROUP = re.compile(r"\[([^\[\]]+)\]")
_WORD = re.compile(r"^\s*(" + "|".join(SOURCE_WORDS) + r")\b", re.IGNORECASE)
_PAGE = re.compile(r"\bpp?\.\s*\d")


def _comment(line: str) -> str:
    """The comment of a TOML line ("" when none), skipping ``#`` inside quoted strings."""
    quote = ""
    for i, ch in enumerate(line):
        if quote:
            if ch == quote:
                quote = ""
        elif ch in "\"'":
            quote = ch
        elif ch == "#":
            return line[i + 1:]
    return ""


def _tag(comment: str) -> str:
    """The last bracketed source tag of a comment, without its brackets ("" when none)."""
    group: str  # the pattern has one group: findall gives its strings
    for group in reversed(_GROUP.findall(comment)):
        if _WORD.match(group) or _PAGE.search(group):
            return group.strip()
    return ""


def source_tags(text: str) -> dict[str, str]:
    """File key path → source tag, for every key line whose comment carries one.

    Parameters
    ----------
    text : str
        Scenario TOML text.

    Returns
    -------
    dict of str to str
        E.g. ``{"controller.kappa_per_s2": "reconstructed: spec §2.3 example"}``.

    Examples
    --------
    >>> text = '''
    ... seed = 1                 # random seed [-]
    ... [[train.vehicle]]
    ... mass_t = 42.8            # mass [t] [reconstructed from seed 000]
    ... [[train.vehicle]]
    ... mass_t = 48.0            # mass [t] [seed 000: Li & Zheng p.299]
    ... [controller]             # the law [paper]
    ... prediction_horizon = 40  # P [steps] = 2 s
    ... r_per_kn2 = 0.4          # weight [per kN²] [trainctl: see the note]
    ... '''
    >>> for key, tag in source_tags(text).items():
    ...     print(key, "->", tag)
    train.vehicle[0].mass_t -> reconstructed from seed 000
    train.vehicle[1].mass_t -> seed 000: Li & Zheng p.299
    controller -> paper
    controller.r_per_kn2 -> trainctl: see the note
    """
    tags: dict[str, str] = {}
    table = ""
    counts: dict[str, int] = {}
    for line in text.splitlines():
        match = _ARRAY_TABLE.match(line)
        if match:
            name = _dotted(match.group(1))
            counts[name] = counts.get(name, -1) + 1
            table = f"{name}[{counts[name]}]"
        else:
            match = _TABLE.match(line)
            if match:
                table = _dotted(match.group(1))
        if match:
            tag = _tag(match.group(2) or "")
            if tag:
                tags[table] = tag
            continue
        match = _KEY.match(line)
        if not match:
            continue
        tag = _tag(_comment(line))
        if tag:
            key = _dotted(match.group(1))
            tags[f"{table}.{key}" if table else key] = tag
    return tags


def _dotted(name: str) -> str:
    """``a . b`` → ``a.b``, quotes dropped."""
    return ".".join(part.strip().strip('"') for part in name.split("."))
