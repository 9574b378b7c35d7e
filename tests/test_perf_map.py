"""``tools/perf_map``: the map lists freshly compiled functions where numba put them, numba's
mangled names read back, and a leaf's samples are counted against the function its return
address falls in (a hand-built ``perf script -D`` dump; the real one needs ``perf``)."""

from __future__ import annotations

import numba
import numpy as np

from cobotsafety.tools.perf_map import leaf_callers, read_perf_map, short_name, write_perf_map


@numba.njit  # no cache: compiled in this process, so its LLVM module is there to list
def _weighted_sum(x, w):  # pragma: no cover - compiled
    s = 0.0
    for i in range(x.shape[0]):
        s += x[i] * w[i]
    return s


def test_the_map_lists_a_fresh_function_at_its_address(tmp_path):
    from cobotsafety.tools.perf_map import jit_functions

    assert _weighted_sum(np.ones(3), np.arange(3.0)) == 3.0
    (result,) = _weighted_sum.overloads.values()
    native = result.library.get_pointer_to_function(result.fndesc.llvm_func_name)
    functions, cached = jit_functions(__name__)
    assert cached == 0 and functions[native] == result.fndesc.llvm_func_name
    path = write_perf_map(functions, tmp_path / "perf-1.map")
    rows = read_perf_map(path)
    assert [start for start, _, _ in rows] == sorted(functions)
    start, size, name = next(row for row in rows if row[0] == native)
    assert name == result.fndesc.llvm_func_name and size > 0
    assert short_name(name).endswith("test_perf_map._weighted_sum")


def test_numbas_mangled_names_read_back():
    symbol = "_ZN11cobotsafety3arm11step_kernel8arm_stepB2v7B40c8tJTIeFIjxB2IKSgI4CrvSCKg1MMfAwK4LIaQIAE5ArrayIdLi1E1C7"
    assert short_name(symbol) == "cobotsafety.arm.step_kernel.arm_step"
    assert short_name("NRT_incref") == "NRT_incref"


def _sample(ip: int, return_address: int) -> str:
    """One sample as ``perf script -D`` prints it: the raw event's bytes (16 of header, the
    user stack's u64 size at 0x10, then the stack from the stack pointer) and its summary."""
    raw = bytes(16) + (16).to_bytes(8, "little") + return_address.to_bytes(8, "little") + bytes(8)
    lines = [f".  {i:04x}:  " + " ".join(f"{b:02x}" for b in raw[i:i + 16]) + " " for i in range(0, len(raw), 16)]
    return ("\n0x100@perf.data [0x138]: event: 9\n.\n. ... raw event: size 48 bytes\n" + "\n".join(lines)
            + f"\n\n1 0x100 [0x138]: PERF_RECORD_SAMPLE(IP, 0x2): 7/7: {ip:#x} period: 1 addr: 0\n"
            + "... ustack: size 16, offset 0x10\n")


def test_a_leafs_samples_go_to_the_function_its_return_address_is_in():
    functions = [(0x1000, 0x100, "_ZN11cobotsafety3arm5human4rowsB2v1B4abcdE"), (0x2000, 0x10, "NRT_incref"),
                 (0x2010, 0x10, "NRT_decref"), (0x3000, 0x400, "_ZN11cobotsafety3arm11step_kernel8arm_stepB2v7BE")]
    dump = "".join([_sample(0x2004, 0x1080), _sample(0x2014, 0x3010), _sample(0x2004, 0x3200),
                    _sample(0x3100, 0x1000), _sample(0x2004, 0x9999)])
    total, in_leaves, callers = leaf_callers(dump, functions)
    assert (total, in_leaves) == (5, 4)
    assert callers == {"cobotsafety.arm.step_kernel.arm_step": 2, "cobotsafety.arm.human.rows": 1, "0x9999": 1}


def test_bad_arguments_are_refused_in_one_line(tmp_path, capsys):
    import pytest

    from cobotsafety.tools.perf_map import main

    for argv in (["callers", str(tmp_path / "missing.data"), str(tmp_path / "missing.map")], ["--seconds", "-1"],
                 ["--robot", "nope"], ["callers", __file__, __file__, "--top", "0"]):
        with pytest.raises(SystemExit) as exit_info:
            main(argv)
        assert exit_info.value.code == 2, argv
        assert "error: argument" in capsys.readouterr().err
    assert main(["callers", __file__, __file__]) == 2  # a Python file is no perf map
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is not a perf map" in err
