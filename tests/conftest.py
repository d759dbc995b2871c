"""Shared test helpers, and the check that the suite tests the installed package."""

import functools
import json
import os
import shutil
import sys
import tempfile
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import cold_children
import numpy as np
import pytest
from xdist.scheduler import LoadScopeScheduling

#: The repository (or the fresh copy CI runs in) that holds these tests.
REPOSITORY = Path(__file__).resolve().parents[1]

#: The packages beside ``synth`` in the repository, which are not installed: the tests of the
#: benchmarks and of the thesis study import them from here. The repository goes last on
#: ``sys.path``, after the installed packages, so that ``synth`` stays the installed one.
CHECKOUT_PACKAGES = ("benchmarks", "validation")
if str(REPOSITORY) not in sys.path:
    sys.path.append(str(REPOSITORY))


def _editable_install_of(folder: Path) -> bool:
    """True if an installed distribution of the project is an editable install of ``folder``
    (pip records it in ``direct_url.json``, PEP 610)."""
    for dist in metadata.distributions(name="impact-synth"):
        record = json.loads(dist.read_text("direct_url.json") or "{}")
        url = Path(record.get("url", "").removeprefix("file://"))
        if record.get("dir_info", {}).get("editable", False) and url == folder:
            return True
    return False


def pytest_configure(config):
    """Refuse to run against this checkout's source tree unless it is what is installed (an
    editable install of it): the suite tests what a user installs, so ``import synth`` must
    resolve to the installed package (``pip install .`` then ``pytest``; ``python -m pytest``
    would put the checkout first on ``sys.path``)."""
    import synth

    where = Path(synth.__file__).resolve()
    if where.parent == REPOSITORY / "synth" and not _editable_install_of(REPOSITORY):
        raise pytest.UsageError(
            f"the tests import synth from the source tree ({where}), not from the installed "
            "package: run `pip install .` (or `pip install -e .` to develop) and then `pytest`, "
            "not `python -m pytest`"
        )
    _check_checkout_packages()
    # The Pythons the tests start (``python -c``, ``python -m synth``) run in the checkout:
    # without this they would put it first on ``sys.path`` and import its source tree, not
    # the installed package (PYTHONSAFEPATH, Python 3.11).
    os.environ.setdefault("PYTHONSAFEPATH", "1")


#: The kernel groups a second process compiles while the tests run, on an empty numba
#: cache (synth.warmup.start_ahead), in this order: the stiff contact's and the live
#: engine's, which the presets' renders (the first tests' kernels) do not compile. The
#: stiff contact goes first: the contact tests need it before the live tests need theirs.
#: A run spread over pytest-xdist workers (``-n``) compiles them ahead too, started by the
#: controller, so that the workers load these groups rather than each compile them; the
#: other kernels each worker compiles when it meets them first, into the numba disk cache
#: the other then loads from. Set SYNTH_TEST_AHEAD=0 to compile everything in the test
#: processes.
AHEAD_GROUPS = ("stiff-contact", "live", "live-rolling")
#: A run of at least this many tests, or of a live engine's test file, compiles ahead.
AHEAD_MIN_TESTS = 200
_AHEAD = pytest.StashKey()
#: The lock folder the controller of a run over workers gives them (before they start) and
#: its compiling process then holds (:data:`synth.compilation.LOCKS`).
_LOCK_FOLDER = pytest.StashKey()
#: The controller's folder of the workers' groups (:data:`GROUPS_FOLDER`).
_GROUPS = pytest.StashKey()
#: The CPU seconds the controller of a run over workers gathers from each worker.
_WORKERS_CPU = pytest.StashKey()
#: The controller's folder of the cold children it runs beside the tests, and their thread.
_COLD = pytest.StashKey()


def _is_worker(config) -> bool:
    """True in a pytest-xdist worker process."""
    return hasattr(config, "workerinput")


#: The pytest-xdist group of the tests that read :func:`preset_run_from_empty_caches` (the
#: frozen renders, the round trip), one per preset (``preset-runs:NAME``): its render is
#: cached in the process, so the tests of a preset run on one worker, which renders it once,
#: and the presets' renders spread over the workers.
PRESET_RUN_GROUP = "preset-runs"


def _preset_run_group(item) -> str:
    """The :data:`PRESET_RUN_GROUP` of a test that reads ``preset_run``: its preset is its
    parameter ``name`` or the argument of its ``preset`` mark; one group for all the tests
    whose preset neither names."""
    mark = item.get_closest_marker("preset")
    params = getattr(getattr(item, "callspec", None), "params", {})
    name = mark.args[0] if mark is not None else params.get("name")
    return PRESET_RUN_GROUP if name is None else f"{PRESET_RUN_GROUP}:{name}"


def _reads_cold_children_beside(item) -> bool:
    """True for a test that reads the cold children which the controller of this worker
    runs beside the tests (:data:`cold_children.FOLDER`)."""
    return bool(os.environ.get(cold_children.FOLDER)) and "cold_children" in getattr(
        item, "fixturenames", ()
    )


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """The tests that read the fixture ``preset_run`` in their preset's group
    (:func:`_preset_run_group`, before pytest-xdist names the groups). In a pytest-xdist
    worker, the files with the most tests marked slow first, then the files with the most
    tests: the workers take files in this order (:class:`FileOrGroupScheduling`), so that a
    long file starts early rather than last, when the other worker would have nothing left
    to run beside it."""
    for item in items:
        if "preset_run" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.xdist_group(_preset_run_group(item)))
    if not _is_worker(config):
        return
    _write_groups(config, items)
    slow: dict[Path, int] = {}
    count: dict[Path, int] = {}
    for item in items:
        slow[item.path] = slow.get(item.path, 0) + (item.get_closest_marker("slow") is not None)
        count[item.path] = count.get(item.path, 0) + 1
    items.sort(key=lambda item: (-slow[item.path], -count[item.path], str(item.path)))


def _cold_children_last(items) -> bool:
    """In a pytest-xdist worker whose controller runs the cold children beside the tests
    (:data:`cold_children.FOLDER`): the files of the selected tests that read them moved
    last (in place, in their order), when the children are likely done; True if any."""
    cold = {item.path for item in items if _reads_cold_children_beside(item)}
    items.sort(key=lambda item: item.path in cold)
    return bool(cold)


#: Environment variable: the folder in which each pytest-xdist worker writes the groups of
#: its tests (``xdist_group`` marks, a JSON object nodeid -> group) for the controller's
#: :class:`FileOrGroupScheduling`: pytest-xdist's own mark of a group on the test's id does
#: not reach pytest 9's ids.
GROUPS_FOLDER = "SYNTH_TEST_XDIST_GROUPS"


def _write_groups(config, items) -> None:
    """A worker's groups of its tests, written whole (atomically) into :data:`GROUPS_FOLDER`."""
    folder = os.environ.get(GROUPS_FOLDER)
    if not folder:
        return
    groups = {}
    for item in items:
        mark = item.get_closest_marker("xdist_group")
        if mark is not None:
            groups[item.nodeid] = str(mark.args[0] if mark.args else mark.kwargs["name"])
    path = Path(folder) / f"{config.workerinput['workerid']}.json"
    part = path.with_suffix(".part")
    part.write_text(json.dumps(groups))
    os.replace(part, path)


def _read_groups() -> dict[str, str]:
    """The groups the workers wrote (:func:`_write_groups`), nodeid -> group."""
    folder = os.environ.get(GROUPS_FOLDER)
    groups = {}
    for path in sorted(Path(folder).glob("*.json")) if folder else ():
        groups.update(json.loads(path.read_text()))
    return groups


def _is_controller(config) -> bool:
    """True in the process that runs pytest-xdist workers (``-n`` 1 or more)."""
    return config.pluginmanager.has_plugin("dsession")


def _ahead_wanted(count: int, files) -> bool:
    """True if a run of ``count`` tests in the files named ``files`` compiles ahead."""
    return count >= AHEAD_MIN_TESTS or any(f.startswith("test_live") for f in files)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_auto_num_workers(config):
    """``-n auto`` (pyproject.toml's default): a worker per usable core for a run of a folder
    or of several files; none (the tests in this process) on one core, or for a run of one
    file or of tests of one file, which one worker would run alone
    (:class:`FileOrGroupScheduling`)."""
    cores = len(os.sched_getaffinity(0))
    paths = [config.invocation_params.dir / arg.split("::", 1)[0] for arg in config.args]
    several = any(p.is_dir() for p in paths) or len({p.resolve() for p in paths}) > 1
    return cores if cores > 1 and several else 0


def pytest_sessionstart(session):
    """The controller of a run over workers: a folder for the workers' groups
    (:data:`GROUPS_FOLDER`) and an empty lock folder in the environment the workers start
    with: each kernel's lock while a process compiles it (the workers start alike, so one
    compiles what the other then loads, :data:`synth.compilation.KERNEL_LOCKS`), and the
    groups' (:data:`synth.compilation.LOCKS`), which the folder holds once the controller
    compiles ahead (:func:`pytest_xdist_node_collection_finished`)."""
    config = session.config
    if not _is_controller(config):
        return
    groups = Path(tempfile.mkdtemp(prefix="synth-xdist-groups-"))
    config.stash[_GROUPS] = groups
    os.environ[GROUPS_FOLDER] = str(groups)
    from synth.compilation import KERNEL_LOCKS, LOCKS

    folder = Path(tempfile.mkdtemp(prefix="synth-compile-locks-"))
    config.stash[_LOCK_FOLDER] = folder
    os.environ[KERNEL_LOCKS] = str(folder)
    if os.environ.get("SYNTH_TEST_AHEAD") != "0":
        os.environ[LOCKS] = str(folder)
        cold = Path(tempfile.mkdtemp(prefix="synth-cold-"))
        config.stash[_COLD] = [cold, None]
        os.environ[cold_children.FOLDER] = str(cold)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_node_collection_finished(node, ids):
    """The controller, once the first worker has collected (before any test runs): start
    compiling :data:`AHEAD_GROUPS` ahead into the workers' lock folder for a run that
    reaches them, and the cold children beside the tests for a run that reads them (the
    worker's note, :func:`cold_children.mark_wanted`)."""
    config = node.config
    folder = config.stash.get(_LOCK_FOLDER, None)
    if folder is None or _AHEAD in config.stash or os.environ.get("SYNTH_TEST_AHEAD") == "0":
        return
    files = {nodeid.split("::", 1)[0].rsplit("/", 1)[-1] for nodeid in ids}
    if _ahead_wanted(len(ids), files):
        from synth import warmup

        config.stash[_AHEAD] = warmup.start_ahead(list(AHEAD_GROUPS), folder)
    else:
        config.stash[_AHEAD] = None
    if _COLD in config.stash and not config.option.collectonly:
        config.stash[_COLD][1] = cold_children.start_for_workers(config.stash[_COLD][0])


@pytest.hookimpl(tryfirst=True)
def pytest_collection_finish(session):
    """On an empty numba cache, start compiling :data:`AHEAD_GROUPS` in a second process
    (the machine's second core) for a run in one process that reaches them, and the cold
    children of tests/test_cold.py beside the tests for such a run that reads them. A
    pytest-xdist worker whose selected tests read them tells its controller, which runs
    them (:func:`cold_children.start_for_workers`), and moves their files last
    (:func:`_cold_children_last`), before pytest-xdist sends the controller its tests."""
    config = session.config
    if os.environ.get("SYNTH_TEST_AHEAD") == "0" or config.option.collectonly:
        return
    if _is_worker(config):
        if _cold_children_last(session.items):
            cold_children.mark_wanted(Path(os.environ[cold_children.FOLDER]))
        return
    if _ahead_wanted(len(session.items), {item.path.name for item in session.items}):
        from synth import warmup

        config.stash[_AHEAD] = warmup.start_ahead(list(AHEAD_GROUPS))
    if any("cold_children" in getattr(item, "fixturenames", ()) for item in session.items):
        cold_children.start_early()


@dataclass(frozen=True)
class ProcessCpu:
    """The CPU seconds (user + system) of a test process and of the children it waited for
    (the Pythons the tests start, the process compiling ahead among them)."""

    own: float
    children: float

    @classmethod
    def of_this_process(cls) -> "ProcessCpu":
        import resource

        own = resource.getrusage(resource.RUSAGE_SELF)
        children = resource.getrusage(resource.RUSAGE_CHILDREN)
        return cls(own.ru_utime + own.ru_stime, children.ru_utime + children.ru_stime)


def pytest_sessionfinish(session):
    """Stop the compiling process if it still runs; say so if it failed. Remove the cold
    children's folder (the controller's once they have ended). A worker sends its CPU
    seconds to the controller (pytest-xdist's ``workeroutput``)."""
    config = session.config
    ahead = config.stash.get(_AHEAD, None)
    errors = ahead.finish() if ahead is not None else None
    if errors:
        print(f"\nthe process compiling {ahead.names} ahead failed:\n{errors}", file=sys.stderr)
    if _is_worker(config):
        cpu = ProcessCpu.of_this_process()
        config.workeroutput["synth_cpu"] = (cpu.own, cpu.children)
    folder = config.stash.get(_LOCK_FOLDER, None)
    if folder is not None:  # the controller's, if no process compiled ahead into it
        from synth.compilation import KERNEL_LOCKS, LOCKS

        os.environ.pop(LOCKS, None)
        os.environ.pop(KERNEL_LOCKS, None)
        shutil.rmtree(folder, ignore_errors=True)
    if _GROUPS in config.stash:
        os.environ.pop(GROUPS_FOLDER, None)
        shutil.rmtree(config.stash[_GROUPS], ignore_errors=True)
    if _COLD in config.stash:  # the controller's cold children, once they have ended
        cold, thread = config.stash[_COLD]
        if thread is not None:
            thread.join()
        os.environ.pop(cold_children.FOLDER, None)
        shutil.rmtree(cold, ignore_errors=True)
    cold_children.remove_folder()


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    """Keep a finished worker's CPU seconds for the summary (pytest-xdist's controller)."""
    figures = getattr(node, "workeroutput", {}).get("synth_cpu")
    if figures is not None:
        node.config.stash.setdefault(_WORKERS_CPU, {})[node.gateway.id] = ProcessCpu(*figures)


class FileOrGroupScheduling(LoadScopeScheduling):
    """pytest-xdist's ``loadgroup`` with the tests of a file as the unit of work (its module
    fixtures computed once), except the tests marked ``xdist_group(NAME)``: those of every
    file with that mark are one unit, run on one worker in turn (they share something a
    second worker must not use at the same time). The groups are those the workers wrote
    (:data:`GROUPS_FOLDER`), read once all have collected."""

    _groups: dict[str, str] | None = None

    def _split_scope(self, nodeid: str) -> str:
        if self._groups is None:
            self._groups = _read_groups()
        if nodeid in self._groups:
            return "@" + self._groups[nodeid]
        return nodeid.split("::", 1)[0]


@pytest.hookimpl(optionalhook=True, tryfirst=True)
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadgroup`` runs a file's tests together, not one by one, and the tests of
    one ``xdist_group`` mark together: :class:`FileOrGroupScheduling`."""
    if config.getvalue("dist") != "loadgroup":
        return None
    return FileOrGroupScheduling(config, log)


def pytest_terminal_summary(terminalreporter, config):
    """The CPU time (user + system) of the test process, of the children it waited for (the
    Pythons the tests start), and of the process that compiled ahead; over pytest-xdist
    workers, each worker's and their children's: a test process's own time is the
    critical path of a run on two cores."""
    workers = config.stash.get(_WORKERS_CPU, None)
    ahead = config.stash.get(_AHEAD, None)
    ahead_s = ahead.cpu_seconds if ahead is not None else 0.0
    if workers:
        each = " + ".join(f"{workers[w].own:.1f}" for w in sorted(workers))
        children = sum(cpu.children for cpu in workers.values())
        line = f"CPU s: {len(workers)} test processes {each}, their children {children:.1f}"
        if config.stash.get(_COLD, [None, None])[1] is not None:
            # the controller's children: the workers, the process compiling ahead, the cold
            # children
            rest = ProcessCpu.of_this_process().children - ahead_s
            rest -= sum(cpu.own + cpu.children for cpu in workers.values())
            line += f", cold children {rest:.1f}"
    else:
        cpu = ProcessCpu.of_this_process()
        line = f"CPU s: test process {cpu.own:.1f}, its children {cpu.children - ahead_s:.1f}"
    if ahead is not None:
        stopped = ", stopped at the end" if ahead.stopped else ""
        line += f", compiling {', '.join(ahead.names)} ahead {ahead_s:.1f}{stopped}"
    terminalreporter.write_sep("-", line)


def _check_checkout_packages():
    """Refuse to run if ``benchmarks`` or ``validation`` would be imported from elsewhere than
    this repository (an installed package of the same name comes first on ``sys.path``)."""
    from importlib.util import find_spec

    for name in CHECKOUT_PACKAGES:
        spec = find_spec(name)
        where = Path(spec.origin).resolve().parent if spec and spec.origin else None
        if where != REPOSITORY / name:
            raise pytest.UsageError(
                f"the tests import {name} from {where}, not from the repository's "
                f"{REPOSITORY / name}: another package of that name is installed"
            )


def python_blocks(page: str) -> list[str]:
    """The Python code blocks (```python fences) of the Markdown file ``page`` (a path from
    the repository's root), in order: the examples users copy."""
    text = (REPOSITORY / page).read_text()
    return [part.split("```", 1)[0] for part in text.split("```python")[1:]]


def _damage(path, how, array=None):
    """Damage the cache file ``path`` (``.npz``) in one of the ways a reader must survive:
    ``garbage`` (not an npz file), ``truncate`` (half of it), ``wrong-key`` (another key
    stored), ``wrong-shape`` (``array`` one element short) or ``nan`` (``array`` NaN)."""
    data = path.read_bytes()
    if how == "garbage":
        path.write_bytes(b"not an npz file")
        return
    if how == "truncate":
        path.write_bytes(data[: len(data) // 2])
        return
    with np.load(path) as z:
        arrays = dict(z)
    if how == "wrong-key":
        arrays["key"] = np.array("something else")
    elif how == "wrong-shape":
        arrays[array] = arrays[array][:-1]
    elif how == "nan":
        arrays[array] = np.full_like(arrays[array], np.nan)
    else:
        raise ValueError(f"unknown damage {how!r}")
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)


@pytest.fixture
def damage_cache_file():
    """A function ``damage(path, how, array=None)`` that damages a cache file."""
    return _damage


@pytest.fixture
def empty_caches(tmp_path, monkeypatch):
    """A private, empty disk cache and empty memory caches of plate modes and radiation
    gains (a render then starts from a fresh mode solve)."""
    from synth.physics import modes
    from synth.sound import radiation

    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "cache"))
    modes.clear_memory_cache()
    radiation.clear_memory_cache()
    yield
    modes.clear_memory_cache()
    radiation.clear_memory_cache()


@functools.cache
def _scipy_reference(case):
    """scipy's Radau at rtol 1e-12 for a :class:`benchmarks.contact.ContactCase`: (e, tau)."""
    from benchmarks.contact import scipy_contact

    ref = scipy_contact(case)
    return ref.restitution, ref.contact_time


def _assert_honours_rtol(case, rtol):
    from synth.physics.contact import solve_contact

    r = solve_contact(rtol=rtol, **case.solver_arguments())
    assert r.success, r.message
    e_ref, tau_ref = _scipy_reference(case)
    if e_ref == 0.0:
        assert r.settled and r.restitution == 0.0
        return
    assert abs(r.restitution - e_ref) / e_ref < rtol
    assert abs(r.contact_time - tau_ref) / tau_ref < rtol


@pytest.fixture
def assert_honours_rtol():
    """A function ``check(case, rtol)``: the engine's contact solver at ``rtol`` against
    scipy's Radau at rtol 1e-12 (an independent implementation of the same equations) on a
    :class:`benchmarks.contact.ContactCase`: the relative errors of e and tau are below
    ``rtol``; a settled contact has e = 0 exactly (its tau is when settling is proven, not
    compared)."""
    return _assert_honours_rtol


@dataclass(frozen=True)
class PresetRun:
    """A preset rendered and analysed once per session (:func:`preset_run_from_empty_caches`)."""

    scene: object  # synth.physics.scene.Scene
    render: object  # synth.sound.render.Render
    analysis: object  # synth.analysis.Analysis


@functools.cache
def preset_run_from_empty_caches(name: str, overrides: tuple[str, ...] = ()) -> PresetRun:
    """The preset ``name`` rendered as its file sets it but without normalisation
    (``normalize="none"``: its physical units), from empty caches (a private cache folder and
    empty memory caches, so a fresh mode solve, as on a machine that never rendered it), and
    analysed with the analysis' defaults at the scene's gravity; ``overrides`` as ``--set``.
    Computed once per session: the frozen renders (tests/test_frozen_renders.py, which
    tests/data/record_preset_renders.py records) and the round trip (tests/test_roundtrip.py)
    read the same run."""
    import synth
    from synth.physics import modes
    from synth.sound import radiation

    old = os.environ.get("SYNTH_CACHE_DIR")
    try:
        with tempfile.TemporaryDirectory(prefix="synth-preset-") as tmp:
            os.environ["SYNTH_CACHE_DIR"] = tmp
            modes.clear_memory_cache()
            radiation.clear_memory_cache()
            render = synth.render_preset(name, overrides=overrides, normalize="none")
    finally:
        if old is None:
            os.environ.pop("SYNTH_CACHE_DIR", None)
        else:
            os.environ["SYNTH_CACHE_DIR"] = old
        modes.clear_memory_cache()
        radiation.clear_memory_cache()
    scene = synth.load_preset(name, overrides=list(overrides))
    analysis = synth.analyze(render.audio, render.samplerate, gravity=scene.gravity)
    return PresetRun(scene, render, analysis)


@pytest.fixture(scope="session")
def preset_run():
    """A function ``name -> PresetRun``: :func:`preset_run_from_empty_caches`."""
    return preset_run_from_empty_caches


def _dashpot_point(plate, position=None):
    from synth.physics import impedance
    from synth.physics import modal_contact as mc

    empty = np.zeros(0)
    return mc.ModalPoint(
        plate=plate,
        position=plate.centre if position is None else position,
        max_frequency=1.0,
        omega=empty,
        sigma=empty,
        coupling=empty,
        rigid_coupling=0.0,
        residual_admittance=1.0 / impedance.infinite_plate_impedance(plate),
        residual_rate=0.0,
    )


@pytest.fixture
def dashpot_point():
    """A function ``(plate, position=None) -> ModalPoint`` with no modes, no rigid body and a
    residual of rate 0: a pure dashpot of admittance ``1 / Z_inf`` (s/kg), i.e. the modal
    contact reduced exactly to the impedance model (at the plate's centre by default)."""
    return _dashpot_point


def analysis_tick(time, restitution=None, speed=None, decay_time=0.01, flags=()):
    """An analysis :class:`~synth.analysis.report.Tick` at ``time`` s for scoring and validity
    tests: unit energy and peak, a 1 kHz centroid, a 20 ms window, a strength of 10."""
    from synth.analysis.report import Tick

    return Tick(
        index=1,
        time=time,
        bounce_time=None,
        restitution=restitution,
        speed=speed,
        energy=1.0,
        peak=1.0,
        centroid=1000.0,
        spread=100.0,
        decay_time=decay_time,
        window=0.02,
        strength=10.0,
        flags=tuple(flags),
    )
