# numpydoc validation of every public function and class.
"""The public API's docstrings pass numpydoc's validation checks.

The public API is what the documentation describes (``docs/apigen.py``):
every name in ``__all__`` of every module under ``trainctl`` whose dotted
name has no part starting with an underscore. Functions and classes are
checked once each (a re-exported object is the same object), against the
checks listed in ``pyproject.toml`` under ``[tool.numpydoc_validation]``;
the public methods of public classes against the same checks except an
Examples section (:data:`METHOD_EXEMPT`).
A class is validated with its constructor's parameters, so its Parameters
section must list them; a Protocol has no constructor of its own, and its
``*args, **kwargs`` are not asked for. numpydoc leaves a function's ``cls``
parameter out of the signature it compares with, so a documented ``cls`` is
not called unknown.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import tomllib
from collections.abc import Callable, Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

import trainctl

numpydoc_validate = pytest.importorskip("numpydoc.validate")

ROOT = Path(__file__).resolve().parents[1]


def _checks() -> set[str]:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    checks = config["tool"]["numpydoc_validation"]["checks"]
    assert checks and all(isinstance(code, str) for code in checks)
    return set(checks)


CHECKS = _checks()


def public_modules() -> Iterator[ModuleType]:
    """Every public module of trainctl: no underscore part in its name, with ``__all__``."""
    if hasattr(trainctl, "__all__"):
        yield trainctl
    for info in pkgutil.walk_packages(trainctl.__path__, "trainctl."):
        if any(part.startswith("_") for part in info.name.split(".")):
            continue
        module = importlib.import_module(info.name)
        if hasattr(module, "__all__"):
            yield module


def public_objects() -> dict[str, Any]:
    """Each public function and class once, by the dotted name numpydoc imports it by."""
    found: dict[int, tuple[str, Any]] = {}
    for module in public_modules():
        for name in module.__all__:
            obj = getattr(module, name)
            if not (inspect.isfunction(obj) or inspect.isclass(obj)):
                continue
            if id(obj) not in found:
                found[id(obj)] = (f"{obj.__module__}.{obj.__qualname__}", obj)
    return dict(found.values())


def problems(name: str, obj: Any, checks: set[str] = CHECKS) -> list[str]:
    """numpydoc's errors for one object, limited to ``checks``, as ``CODE message``."""
    errors = numpydoc_validate.validate(name)["errors"]
    if inspect.isclass(obj) and getattr(obj, "_is_protocol", False):
        # A Protocol's signature is (*args, **kwargs) from typing, not its own.
        errors = [(code, message) for code, message in errors
                  if not (code == "PR01" and "'*args'" in message and "'**kwargs'" in message)]
    if inspect.isfunction(obj) and "cls" in inspect.signature(obj).parameters:
        # numpydoc drops a parameter named cls (it takes it for a classmethod's),
        # then calls the documented one unknown.
        errors = [(code, message) for code, message in errors
                  if not (code == "PR02" and message.endswith("{'cls'}"))]
    return [f"{code} {message}" for code, message in errors if code in checks]


METHOD_EXEMPT = frozenset({"EX01"})
"""The check public methods are not held to: an Examples section (their class's
Examples show them). Every other configured check applies to them, so a method
without a docstring (GL08), with an undocumented or unknown parameter (PR01,
PR02), without a Returns or Yields section (RT01, YD01) or with a badly laid out
docstring fails."""


def public_methods() -> dict[str, Any]:
    """The public methods (also class and static methods) defined by public classes.

    Properties and inherited methods are left out; a method is checked with
    the class that defines it.
    """
    found: dict[str, Any] = {}
    for name, cls in public_objects().items():
        if not inspect.isclass(cls) or not cls.__module__.startswith("trainctl."):
            continue
        for attribute, member in vars(cls).items():
            if attribute.startswith("_"):
                continue
            if isinstance(member, staticmethod | classmethod):
                member = member.__func__
            if inspect.isfunction(member):
                found[f"{name}.{attribute}"] = member
    return found


def test_public_api_is_found() -> None:
    """The walk finds the public API (a broken walk would pass the test below vacuously)."""
    objects = public_objects()
    assert len(objects) > 400
    assert trainctl.load_scenario in objects.values()
    assert trainctl.scenario.Scenario in objects.values()
    assert not any(name.split(".")[-1].startswith("_") for name in objects)


def test_public_docstrings_pass_numpydoc() -> None:
    """Every public function and class passes the configured checks; all offenders listed."""
    failures = {name: found for name, obj in sorted(public_objects().items())
                if (found := problems(name, obj))}
    report = "\n".join(f"{name}:\n    " + "\n    ".join(found)
                       for name, found in failures.items())
    assert not failures, f"{len(failures)} public objects fail numpydoc validation:\n{report}"


def test_public_methods_pass_numpydoc() -> None:
    """Public methods pass the configured checks but :data:`METHOD_EXEMPT`; all listed.

    numpydoc cannot read the source of a few methods that pydantic rebuilds
    (a ``SyntaxError`` from its parser); they are left out, at most a handful.
    """
    methods = public_methods()
    assert len(methods) > 300
    failures, unreadable = {}, []
    for name, method in sorted(methods.items()):
        try:
            found = problems(name, method, CHECKS - METHOD_EXEMPT)
        except SyntaxError:
            unreadable.append(name)
            continue
        if found:
            failures[name] = found
    assert len(unreadable) <= 3, unreadable
    report = "\n".join(f"{name}:\n    " + "\n    ".join(found)
                       for name, found in failures.items())
    assert not failures, f"{len(failures)} public methods fail numpydoc validation:\n{report}"


def undocumented_speed(mass, force):  # type: ignore[no-untyped-def]
    """compute a speed"""
    return force / mass


def half_documented(distance: float, time: float) -> float:
    """Average speed over a distance.

    Parameters
    ----------
    distance : float
        Distance covered [m].
    duration : float
        Not a parameter of this function.
    """
    return distance / time


def test_validator_catches_bad_docstrings() -> None:
    """Deliberately bad docstrings fail: the check above can fail."""
    here = __name__
    bad = problems(f"{here}.undocumented_speed", undocumented_speed)
    codes = {entry.split()[0] for entry in bad}
    assert {"PR01", "RT01", "SS03", "EX01"} <= codes, bad
    half = problems(f"{here}.half_documented", half_documented)
    codes = {entry.split()[0] for entry in half}
    assert {"PR01", "PR02", "RT01"} <= codes, half
    assert any("'time'" in entry for entry in half if entry.startswith("PR01"))
    assert any("'duration'" in entry for entry in half if entry.startswith("PR02"))


def test_validator_catches_missing_docstring() -> None:
    """A function without a docstring fails GL08."""
    namespace: dict[str, Callable[..., Any]] = {}
    exec("def bare(x):\n    return x\n", namespace)  # no docstring at all
    bare = namespace["bare"]
    bare.__module__ = __name__
    globals()["bare"] = bare
    try:
        found = problems(f"{__name__}.bare", bare)
    finally:
        del globals()["bare"]
    assert any(entry.startswith("GL08") for entry in found), found


class Carriage:
    """A test class whose method has no docstring."""

    def speed(self, distance: float) -> float:
        return distance


def test_method_check_catches_missing_docstring() -> None:
    """A method without a docstring fails GL08 even with the method exemptions."""
    found = problems(f"{__name__}.Carriage.speed", Carriage.speed, CHECKS - METHOD_EXEMPT)
    assert any(entry.startswith("GL08") for entry in found), found


class Wagon:
    """A test class whose method documents neither its parameter nor its result."""

    def load(self, mass: float) -> float:
        """Load the wagon."""
        return mass


def test_method_check_asks_for_parameters_and_returns() -> None:
    """A method with a docstring but no Parameters or Returns section fails PR01 and RT01."""
    found = problems(f"{__name__}.Wagon.load", Wagon.load, CHECKS - METHOD_EXEMPT)
    codes = {entry.split()[0] for entry in found}
    assert {"PR01", "RT01"} <= codes and "EX01" not in codes, found
