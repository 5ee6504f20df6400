"""Dependencies flow downward (DESIGN.md): checked on the source, every import, including those
inside functions.

stimuli -> numpy, scipy, the standard library only; analysis -> nothing of experiments' runtime;
experiments.hardware -> not the command line, not the session; and inside experiments only the
Figure 9 package (experiments.simulation.figure9: the study, its scenarios against the paper's
claims, ``reproduce figure9``) and the command line (``thermocue analyze``, ``power``,
``reproduce``: the top of the stack) import analysis.
"""
from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("stimuli", "analysis", "experiments", "participants_schema")


def _module_name(path: Path) -> tuple[str, bool]:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    is_package = parts[-1] == "__init__"
    if is_package:
        parts = parts[:-1]
    return ".".join(parts), is_package


def _imports():
    """``(importing module, imported module, line)`` for every import statement of the tree."""
    found = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            module, is_package = _module_name(path)
            tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
            for node in ast.walk(tree):                   # module level and inside functions
                if isinstance(node, ast.Import):
                    found += [(module, alias.name, node.lineno) for alias in node.names]
                elif isinstance(node, ast.ImportFrom):
                    if node.level:                          # relative: resolve against the package
                        base = module.split(".") if is_package else module.split(".")[:-1]
                        base = base[:len(base) - (node.level - 1)]
                        target = ".".join(base + ([node.module] if node.module else []))
                    else:
                        target = node.module
                    found.append((module, target, node.lineno))
                    # ``from experiments import cli`` imports the module experiments.cli
                    found += [(module, f"{target}.{alias.name}", node.lineno) for alias in node.names
                              if (ROOT / Path(*target.split("."), alias.name)).exists()
                              or (ROOT / Path(*target.split("."), f"{alias.name}.py")).exists()]
    return found


IMPORTS = _imports()


def _within(name: str, prefixes) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def _violations(source, allowed_target) -> list[str]:
    return sorted({f"{m} imports {t} (line {line})" for m, t, line in IMPORTS
                   if _within(m, source) and not allowed_target(t, m)})


def test_the_scan_sees_imports_inside_functions():
    # figure9.study imports analysis inside run_figure9_study: the scan must find it, or the rules
    # below would hold vacuously
    assert ("experiments.simulation.figure9.study", "analysis") in {(m, t) for m, t, _ in IMPORTS}
    assert len({m for m, _, _ in IMPORTS if m.startswith("experiments.")}) > 60


def test_stimuli_imports_only_numpy_scipy_and_the_standard_library():
    def allowed(target, _):
        top = target.split(".")[0]
        return top in ("numpy", "scipy", "stimuli", "__future__") or top in sys.stdlib_module_names
    assert _violations(("stimuli",), allowed) == []


#: What analysis must not import: the experiment's runtime. ``experiments.logformat`` (the log
#: format), ``experiments.session_reader`` (the one reader of session folders) and
#: ``experiments.atomicfile`` (files written whole), all standard library only, are the parts of
#: experiments analysis may use.
RUNTIME = ("experiments.session", "experiments.records",
           "experiments.session_files", "experiments.hardware", "experiments.responders",
           "experiments.cli", "experiments.protocol", "experiments.logbook",
           "experiments.schedule", "experiments.psychopy_plugin", "experiments.calibration",
           "experiments.simulation", "experiments.bench")
ANALYSIS_MAY_READ = ("experiments.logformat", "experiments.session_reader", "experiments.atomicfile",
                     "experiments.errors")


def test_analysis_never_imports_the_experiments_runtime():
    def allowed(target, _):
        if _within(target, ANALYSIS_MAY_READ):
            return True
        return not _within(target, RUNTIME) and target != "experiments"
    assert _violations(("analysis",), allowed) == []


@pytest.mark.parametrize("module", ANALYSIS_MAY_READ)
def test_what_analysis_may_use_of_experiments_is_standard_library_only(module):
    def allowed(target, _):
        top = target.split(".")[0]
        return top == "__future__" or top in sys.stdlib_module_names \
            or _within(target, ANALYSIS_MAY_READ) or target == "experiments"
    assert _violations((module,), allowed) == []


def test_hardware_never_imports_the_cli_or_the_session():
    def allowed(target, _):
        return not _within(target, ("experiments.cli", "experiments.session"))
    assert _violations(("experiments.hardware",), allowed) == []


@pytest.mark.parametrize("package", ["participants_schema"])
def test_participants_schema_stands_alone(package):
    def allowed(target, _):
        return not _within(target, ("experiments", "analysis", "stimuli"))
    assert _violations((package,), allowed) == []


#: The parts of experiments that may import analysis.
ANALYSIS_USERS = ("experiments.simulation.figure9", "experiments.cli")


def test_only_the_figure9_package_and_the_cli_import_analysis_from_experiments():
    def allowed(target, module):
        return _within(module, ANALYSIS_USERS) or not _within(target, ("analysis",))
    assert _violations(("experiments",), allowed) == []
