"""See inside the compiled step with Linux ``perf``: ``python -m cobotsafety.tools.perf_map``.

``perf`` samples compiled numba code as bare addresses: nothing tells it where a JIT function
lies. ``write_perf_map`` writes the map file ``perf report`` reads for a process
(``/tmp/perf-PID.map``: start, size and name of every function numba compiled in it). Functions
loaded from numba's on-disk cache have no LLVM module to list, so run with an empty cache
directory (``NUMBA_CACHE_DIR=$(mktemp -d)``): everything is compiled afresh (about a minute).

``python -m cobotsafety.tools.perf_map [--robot panda] [--seconds 60]`` runs ``bench arm``'s
human-aware step (the human refreshed every step, as the control loop gives it), writes the
map and prints the PID to attach to, then steps for ``--seconds``::

    NUMBA_CACHE_DIR=$(mktemp -d) python -m cobotsafety.tools.perf_map &   # wait for "attach"
    perf record --call-graph dwarf,64 -F 3000 -p PID -o step.data -- sleep 8
    perf report -i step.data --no-children --sort symbol
    python -m cobotsafety.tools.perf_map callers step.data /tmp/perf-PID.map

``callers`` answers what ``perf report`` cannot for JIT code (no frame pointers, no unwind
tables): who calls a leaf. A leaf such as numba's reference counts (``NRT_incref``,
``NRT_decref``) sets up no frame, so at a sample inside it the word at the stack pointer is
its return address; ``--call-graph dwarf,64`` records those bytes. ``docs/step_profile.md``
has what it found.
"""

from __future__ import annotations

import argparse
import bisect
import collections
import os
import re
import subprocess
import sys
import time
from pathlib import Path

#: Leaves whose callers ``callers`` counts by default.
REFERENCE_COUNTS = ("NRT_incref", "NRT_decref")


def jit_functions(module_prefix: str = "cobotsafety") -> tuple[dict[int, str], int]:
    """``({address: symbol}, dispatchers without a module)`` of every compiled overload of the
    numba dispatchers in the loaded modules named ``module_prefix*``, their callees included
    (each overload's library holds its own copy of what it calls and does not inline)."""
    import numba

    found: dict[int, str] = {}
    cached = 0
    for module in list(sys.modules.values()):
        if module is None or not getattr(module, "__name__", "").startswith(module_prefix):
            continue
        for value in list(vars(module).values()):
            if not isinstance(value, numba.core.registry.CPUDispatcher):
                continue
            for result in value.overloads.values():
                library = result.library
                final = getattr(library, "_final_module", None)
                if final is None:
                    cached += 1
                    continue
                for function in final.functions:
                    if function.is_declaration:
                        continue
                    address = library.get_pointer_to_function(function.name)
                    if address:
                        found[address] = function.name
    return found, cached


def write_perf_map(functions: dict[int, str], path: Path | None = None) -> Path:
    """Write ``functions`` as ``perf``'s map for this process (each runs to the next one's
    start; the last one 64 KiB). Returns the path."""
    path = Path(f"/tmp/perf-{os.getpid()}.map") if path is None else path
    starts = sorted(functions)
    with path.open("w") as out:
        for i, start in enumerate(starts):
            size = starts[i + 1] - start if i + 1 < len(starts) else 1 << 16
            out.write(f"{start:x} {size:x} {functions[start]}\n")
    return path


def read_perf_map(path: Path) -> list[tuple[int, int, str]]:
    """``[(start, size, name)]`` sorted by start."""
    rows = []
    for line in Path(path).read_text().splitlines():
        start, size, name = line.split(" ", 2)
        rows.append((int(start, 16), int(size, 16), name))
    return sorted(rows)


def short_name(symbol: str) -> str:
    """``cobotsafety.arm.step_kernel.arm_step`` from numba's mangled ``_ZN11cobotsafety3arm...``
    (Itanium's length-prefixed names up to the first part that is not one)."""
    if not symbol.startswith("_ZN"):
        return symbol
    parts, i = [], 3
    while i < len(symbol) and symbol[i].isdigit():
        digits = re.match(r"\d+", symbol[i:]).group(0)
        i += len(digits)
        parts.append(symbol[i:i + int(digits)])
        i += int(digits)
    return ".".join(parts) if parts else symbol


def samples_with_stack(dump: str):
    """``(ip, stack bytes)`` of each sample in ``perf script -D``'s dump (``--call-graph dwarf``
    records: the raw event's hex bytes, and where in them the user stack starts)."""
    for block in dump.split("raw event: size")[1:]:
        if "PERF_RECORD_SAMPLE" not in block:
            continue
        raw = bytearray()
        for line in block.splitlines()[1:]:
            match = re.match(r"\.\s+[0-9a-f]{4}:\s+((?:[0-9a-f]{2} )+)", line)
            if not match:
                break
            raw += bytes.fromhex(match.group(1).replace(" ", ""))
        ip = re.search(r"PERF_RECORD_SAMPLE\([^)]*\): \d+/\d+: (0x[0-9a-f]+)", block)
        stack = re.search(r"ustack: size \d+, offset (0x[0-9a-f]+)", block)
        if ip is None or stack is None:
            continue
        offset = int(stack.group(1), 16) + 8  # a u64 size, then the bytes from the stack pointer
        yield int(ip.group(1), 16), bytes(raw[offset:])


def leaf_callers(dump: str, functions: list[tuple[int, int, str]], leaves=REFERENCE_COUNTS):
    """``(samples, samples in a leaf, Counter of caller name)``: each sample inside one of
    ``leaves`` counted against the function its return address (the stack's first word) is in."""
    starts = [row[0] for row in functions]

    def name_at(address: int) -> str:
        i = bisect.bisect_right(starts, address) - 1
        if i >= 0 and address < functions[i][0] + functions[i][1]:
            return short_name(functions[i][2])
        return hex(address)

    total, in_leaves, callers = 0, 0, collections.Counter()
    for ip, stack in samples_with_stack(dump):
        total += 1
        if any(leaf in name_at(ip) for leaf in leaves) and len(stack) >= 8:
            in_leaves += 1
            callers[name_at(int.from_bytes(stack[:8], "little"))] += 1
    return total, in_leaves, callers


def _run_step(robot: str, seconds: float) -> None:
    from cobotsafety.bench.arm_bench import _beside_a_human

    controller, v = _beside_a_human(robot)
    functions, cached = jit_functions()
    path = write_perf_map(functions)
    if cached:
        print(f"{cached} compiled function(s) came from numba's cache and are not in the map: run with an "
              "empty NUMBA_CACHE_DIR", file=sys.stderr)
    print(f"{len(functions)} functions mapped in {path}; attach: perf record -p {os.getpid()}", flush=True)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for _ in range(1000):
            controller.set_human(controller.human_frame)
            controller.step(v, 0.001)


def main(argv: list[str] | None = None) -> int:
    from cobotsafety.arm.robots import ROBOTS
    from cobotsafety.cli.arguments import existing_file, one_line, positive_int, positive_seconds

    parser = argparse.ArgumentParser(prog="python -m cobotsafety.tools.perf_map", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command")
    callers = sub.add_parser("callers", help="who calls the reference counts, from a perf.data with dwarf stacks")
    callers.add_argument("data", type=existing_file, help="perf.data recorded with --call-graph dwarf")
    callers.add_argument("map", type=existing_file, help="the /tmp/perf-PID.map this tool wrote")
    callers.add_argument("--top", type=positive_int, default=20)
    parser.add_argument("--robot", default="panda", choices=list(ROBOTS))
    parser.add_argument("--seconds", type=positive_seconds, default=60.0)
    args = parser.parse_args(argv)
    if args.command != "callers":
        _run_step(args.robot, args.seconds)
        return 0
    try:
        functions = read_perf_map(Path(args.map))
    except ValueError:
        print(f"perf_map: {args.map} is not a perf map (lines of start, size, name)", file=sys.stderr)
        return 2
    try:
        dump = subprocess.run(["perf", "script", "-i", args.data, "-D"], capture_output=True, text=True,
                              check=True).stdout
    except FileNotFoundError:
        print("perf_map: perf is not installed (linux-perf)", file=sys.stderr)
        return 2
    except subprocess.CalledProcessError as error:
        print(f"perf_map: perf script failed on {args.data}: {one_line(error.stderr)[:200]}", file=sys.stderr)
        return 2
    total, in_leaves, counts = leaf_callers(dump, functions)
    print(f"{total} samples, {in_leaves} ({100.0 * in_leaves / max(total, 1):.1f} %) in {', '.join(REFERENCE_COUNTS)}; "
          "their callers:")
    for name, n in counts.most_common(args.top):
        print(f"{n:7d}  {100.0 * n / max(in_leaves, 1):5.1f} %  {name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
