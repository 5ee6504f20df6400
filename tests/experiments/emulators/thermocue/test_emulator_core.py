"""The one emulator core both transports use (layers that hold)."""
from __future__ import annotations

import ast
from pathlib import Path

import serial

from experiments.display.thermocue import messages as m
from experiments.emulators.thermocue.device import TICK_US
from experiments.emulators.thermocue.emulator_core import MAX_CATCH_UP_TICKS, EmulatorCore
from experiments.display.thermocue.framing import FrameParser, encode_frame

from _ports import HidingPort

EMULATORS = Path(__file__).resolve().parents[4] / "experiments" / "emulators"


def _imported_modules(path: Path) -> set[str]:
    """Every module a file imports, at top level or inside functions."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
    return names


def test_hardware_never_imports_the_cli_or_the_session():
    # pty_server.main imported experiments.cli.emulator, which imported pty_server back
    bad = {}
    for path in sorted(EMULATORS.rglob("*.py")):
        hits = sorted(n for n in _imported_modules(path)
                      if n.split(".")[:2] in (["experiments", "cli"], ["experiments", "session"]))
        if hits:
            bad[path.name] = hits
    assert bad == {}


def test_both_transports_are_built_on_the_core():
    # each wrote the device + link-fault plumbing itself (and injected garbage differently)
    for name in ("thermocue/protocol_emulator.py", "pty_server.py"):
        calls = {node.func.id for node in ast.walk(ast.parse((EMULATORS / name).read_text()))
                 if isinstance(node, ast.Call) and isinstance(node.func, ast.Name)}
        assert "EmulatorCore" in calls and not calls & {"Device", "LinkFaults"}, name


def test_catch_up_computes_at_most_twenty_ticks_then_gives_up_the_lost_time():
    core = EmulatorCore()
    core.start_real_time(100.0)
    n, _ = core.catch_up(100.0 + 0.0349)               # ticks due at 100.01, .02, .03
    assert n == 3 and core.device.time_us == 3 * TICK_US
    assert abs(core.next_tick - 100.04) < 1e-9
    n, _ = core.catch_up(105.0)                        # 5 s late: 20 ticks, then now + 1 tick
    assert n == MAX_CATCH_UP_TICKS and core.device.time_us == 23 * TICK_US
    assert abs(core.next_tick - 105.01) < 1e-9
    assert 4.9 < core.max_late_s < 5.0


def test_late_host_bytes_are_stamped_with_the_device_time_caught_up_to():
    core = EmulatorCore()
    core.start_real_time(0.0)
    assert core.late_stamp_us(0.005) is None                   # not late: stamped now
    assert core.late_stamp_us(0.0101) == 0                     # the first tick is due
    assert core.late_stamp_us(0.0351) == 2 * TICK_US           # 3 ticks due: the last one's time
    assert core.late_stamp_us(60.0) == (MAX_CATCH_UP_TICKS - 1) * TICK_US


def test_garbage_is_drawn_per_tick_not_per_host_write():
    # the in-process transport drew garbage also after every host write, the pty per tick only
    core = EmulatorCore(faults="garbage=1")
    core.to_device(encode_frame(1, m.Cmd.HELLO, m.HELLO_REQ.pack(m.PROTOCOL_VERSION)))
    reply = core.to_host(ticked=False)
    p = FrameParser()
    frames = p.feed(reply)
    assert [f.type for f in frames] == [m.Cmd.HELLO | m.REPLY_BIT] and p.bytes_skipped == 0
    assert len(core.tick()) >= 1                              # p = 1: garbage on every tick


def test_delay_holds_device_bytes_until_their_device_time():
    core = EmulatorCore(faults="delay=0.05")
    core.to_device(encode_frame(1, m.Cmd.HELLO, m.HELLO_REQ.pack(m.PROTOCOL_VERSION)))
    assert core.to_host(ticked=False) == b""
    got = b"".join(core.tick() for _ in range(4))
    assert got == b""                                          # 40 ms: not yet
    late = core.tick() + core.tick()                           # 50 ms (± rounding): it arrives
    assert [f.type for f in FrameParser().feed(late)] == [m.Cmd.HELLO | m.REPLY_BIT]


def test_in_process_port_runs_on_the_core_and_loses_no_reply_to_garbage():
    port = serial.serial_for_url("emulator://?clock=virtual&faults=garbage=1", timeout=0)
    try:
        assert isinstance(port.core, EmulatorCore) and port.device is port.core.device
        port.write(encode_frame(1, m.Cmd.HELLO, m.HELLO_REQ.pack(m.PROTOCOL_VERSION)))
        p = FrameParser()
        assert [f.type for f in p.feed(port.read(4096))] == [m.Cmd.HELLO | m.REPLY_BIT]
        assert p.bytes_skipped == 0
    finally:
        port.close()


def test_the_driver_asks_the_port_for_its_device_clock():
    # the driver read port.device.time_us; now only the documented device_clock()
    from experiments.display.thermocue.driver import ThermalDisplay
    inner = serial.serial_for_url("emulator://?clock=virtual", timeout=0.01)
    d = ThermalDisplay(HidingPort(inner, hide=("device", "core", "virtual_time_s", "link")))
    try:
        info = d.handshake()
        assert info.device_id == "EMU-0001"
        t0 = inner.device.time_us
        d.wait(0.2)                                  # 0.2 s of device time, not of wall time
        assert 0.2e6 <= inner.device.time_us - t0 < 0.25e6
    finally:
        d.close()


def test_the_cli_offers_the_emulator_options_without_importing_the_emulator():
    # pty_server no longer imports the CLI; the CLI must not pay for that by importing the
    # emulator (numpy, scipy, the device) just to build its parser: `thermocue --help` stays fast
    import subprocess
    import sys
    code = ("import sys\n"
            "from experiments.cli import build_parser\n"
            "p = build_parser()\n"
            "ns = p.parse_args(['emulator', '--faults', 'drop=0.1', '--clock', 'virtual'])\n"
            "assert (ns.faults, ns.clock, ns.seed) == ('drop=0.1', 'virtual', 0), ns\n"
            "heavy = [m for m in ('numpy', 'scipy', 'experiments.emulators.thermocue.device',\n"
            "                     'experiments.emulators.pty_server') if m in sys.modules]\n"
            "print(heavy)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=Path(__file__).resolve().parents[4], timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
