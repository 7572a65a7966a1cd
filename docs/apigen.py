"""Write the API reference pages of trainctl into ``docs/api/generated/``.

The public API is every name in ``__all__`` of every public module: a module
under ``trainctl`` whose dotted name has no component starting with an
underscore and which defines ``__all__``. A name re-exported by several
public modules is described once, at its canonical home: the public module
that defines it, or else the public module closest to the private module
that defines it (``trainctl._format`` → ``trainctl.report``). The
other modules list it with a link to that home.

Called by ``conf.py`` at every build; also runnable alone
(``python docs/apigen.py``) to look at the pages it writes.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType

HERE = Path(__file__).resolve().parent
OUT = HERE / "api" / "generated"


@dataclass
class Entry:
    """One public name at its canonical home."""

    module: str
    name: str
    kind: str  # "class", "function" or "data"


@dataclass
class Page:
    """One public module: its own names and the names it re-exports."""

    module: str
    own: list[Entry] = field(default_factory=list)
    reexported: list[tuple[str, Entry]] = field(default_factory=list)


def public_modules() -> list[ModuleType]:
    """Every public module of trainctl, imported, in dotted-name order."""
    import trainctl

    found = [trainctl] if hasattr(trainctl, "__all__") else []
    for info in pkgutil.walk_packages(trainctl.__path__, "trainctl."):
        if any(part.startswith("_") for part in info.name.split(".")):
            continue
        module = importlib.import_module(info.name)
        if hasattr(module, "__all__"):
            found.append(module)
    return sorted(found, key=lambda m: m.__name__)


def _kind(obj: object) -> str:
    if inspect.isclass(obj):
        return "class"
    if inspect.isfunction(obj) or inspect.isbuiltin(obj):
        return "function"
    return "data"


def _closeness(home: str, defining: str) -> tuple[int, int]:
    """Sort key: the longest shared dotted prefix first, then the shortest name."""
    a, b = home.split("."), defining.split(".")
    shared = 0
    while shared < min(len(a), len(b)) and a[shared] == b[shared]:
        shared += 1
    return (-shared, len(a))


def collect() -> list[Page]:
    """The pages of every public module, each name placed at its canonical home."""
    modules = public_modules()
    pages = {m.__name__: Page(m.__name__) for m in modules}
    holders: dict[int, list[tuple[str, str, object]]] = {}
    data: list[tuple[str, str, object]] = []
    for module in modules:
        for name in module.__all__:
            obj = getattr(module, name)
            if _kind(obj) == "data":
                data.append((module.__name__, name, obj))
            else:
                holders.setdefault(id(obj), []).append((module.__name__, name, obj))
    for places in holders.values():
        obj = places[0][2]
        defining = getattr(obj, "__module__", "") or ""
        own = [p for p in places if p[0] == defining and p[1] == obj.__name__]
        home = own[0] if own else min(places, key=lambda p: _closeness(p[0], defining))
        entry = Entry(home[0], home[1], _kind(obj))
        pages[home[0]].own.append(entry)
        for place in places:
            if place[:2] != home[:2]:
                pages[place[0]].reexported.append((place[1], entry))
    # Constants and aliases: identity is no reliable test (small ints, interned
    # strings), so a data name is its own at every module where it is not
    # simply the same object under the same name as in a parent's listing.
    seen: dict[tuple[int, str], Entry] = {}
    for module_name, name, obj in sorted(data, key=lambda d: (-d[0].count("."), d[0])):
        key = (id(obj), name)
        if key in seen:
            pages[module_name].reexported.append((name, seen[key]))
        else:
            seen[key] = Entry(module_name, name, "data")
            pages[module_name].own.append(seen[key])
    return [pages[m.__name__] for m in modules]


def group_of(module: str) -> str:
    """The subpackage a module belongs to, e.g. ``analysis``; ``core`` for top-level modules."""
    parts = module.split(".")
    if len(parts) == 1:
        return "core"
    top = importlib.import_module(".".join(parts[:2]))
    return parts[1] if hasattr(top, "__path__") else "core"


_DIRECTIVE = {"class": "autoclass", "function": "autofunction", "data": "autodata"}


def _title(text: str, mark: str) -> str:
    return f"{text}\n{mark * len(text)}\n"


def module_page(page: Page) -> str:
    """The reStructuredText of one module's page."""
    lines = [_title(page.module, "="), f".. automodule:: {page.module}",
             "   :no-members:", "", f".. currentmodule:: {page.module}", ""]
    if page.own:
        lines += [".. autosummary::", ""]
        lines += [f"   {entry.name}" for entry in page.own]
        lines.append("")
    if page.reexported:
        lines += ["Also available here, described at their home:", ""]
        lines += [f"- ``{name}``: :py:obj:`{entry.module}.{entry.name}`"
                  for name, entry in sorted(page.reexported)]
        lines.append("")
    for entry in page.own:
        lines.append(f".. {_DIRECTIVE[entry.kind]}:: {entry.name}")
        if entry.kind == "class":
            lines += ["   :members:", "   :show-inheritance:"]
        lines.append("")
    return "\n".join(lines)


def write(out: Path = OUT) -> int:
    """Write every module page and one index page per subpackage; return the name count."""
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    pages = collect()
    groups: dict[str, list[Page]] = {}
    for page in pages:
        groups.setdefault(group_of(page.module), []).append(page)
        (out / f"{page.module}.rst").write_text(module_page(page), encoding="utf-8")
    for group, members in groups.items():
        heading = "Top-level modules" if group == "core" else f"trainctl.{group}"
        text = [_title(heading, "="), ".. toctree::", "   :maxdepth: 1", ""]
        text += [f"   {page.module}" for page in members]
        (out / f"group-{group}.rst").write_text("\n".join(text) + "\n", encoding="utf-8")
    order = ["core"] + sorted(g for g in groups if g != "core")
    index = [".. toctree::", "   :maxdepth: 1", ""] + [f"   generated/group-{g}" for g in order]
    (out / "groups.rst.inc").write_text("\n".join(index) + "\n", encoding="utf-8")
    return sum(len(page.own) for page in pages)


if __name__ == "__main__":
    print(write(), "names documented")
