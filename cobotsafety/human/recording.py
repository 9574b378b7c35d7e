"""The recording format (gzip JSON Lines) and its validating loader and writer.

See ``assets/recordings/README.md`` for the full description. In short, line 1 is a header::

    {"format": "cobotsafety-recording", "version": 1, "quaternion_order": "xyzw",
     "time_unit": "s", "length_unit": "m", "description": "...",
     "body": {BodyDimensions fields},
     "scanner": {"x_m", "y_m", "yaw_rad", "height_m"},      # pose in the robot base frame
     "laser": {"angle_min", "angle_increment", "range_min", "range_max", "beams"},
     "imus": {name: {"q_base_imu_init": [x, y, z, w], "q_ref_imu_init": [x, y, z, w]}}}

then one record per line, in non-decreasing time: ``{"t": s, "laser": [ranges, m]}`` (0 means
no return) or ``{"t": s, "imu": name, "q": [x, y, z, w]}`` (orientation in the IMU's own
reference frame). ``imus`` may be empty (a laser-only recording).

``load_recording`` refuses a bad file as a whole with ``RecordingError("file:line: what")``:
truncated or non-JSON lines, NaN/Infinity, time going backwards, wrong shapes, non-unit
quaternions (|norm - 1| > 1e-3), unknown IMU names, and missing streams.
"""

from __future__ import annotations

import gzip
import json
import math
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from cobotsafety.errors import RecordingError
from cobotsafety.human.body import BodyDimensions
from cobotsafety.sensors.scanner_pose import ScannerPose

FORMAT = "cobotsafety-recording"
VERSION = 1
#: Allowed |norm - 1| of a stored quaternion (they are stored with 6 decimals).
QUATERNION_NORM_TOLERANCE = 1e-3
LASER_KEYS = ("angle_min", "angle_increment", "range_min", "range_max", "beams")
SCANNER_KEYS = ("x_m", "y_m", "yaw_rad", "height_m")


@dataclass(frozen=True)
class Recording:
    """A validated recording. Times [s], lengths [m], quaternions xyzw.

    ``laser_t_s`` (n,), ``laser_ranges_m`` (n, beams); ``imu_t_s[name]`` (m,),
    ``imu_q_ref[name]`` (m, 4) unit; ``calibration[name] = (q_base_imu_init, q_ref_imu_init)``.
    """

    body: BodyDimensions
    scanner: ScannerPose
    scanner_height_m: float
    laser: dict
    laser_t_s: np.ndarray
    laser_ranges_m: np.ndarray
    imu_t_s: dict = field(default_factory=dict)
    imu_q_ref: dict = field(default_factory=dict)
    calibration: dict = field(default_factory=dict)
    description: str = ""
    source: str = ""

    @property
    def imu_names(self) -> tuple[str, ...]:
        return tuple(self.calibration)

    @property
    def start_s(self) -> float:
        return float(min([self.laser_t_s[0], *(t[0] for t in self.imu_t_s.values())]))

    @property
    def end_s(self) -> float:
        return float(max([self.laser_t_s[-1], *(t[-1] for t in self.imu_t_s.values())]))


_NUMBER_TYPES = {int, float}


def _refuse_constant(name: str):
    raise ValueError(f"{name} is not a number")


def _numbers(where: str, value, shape_text: str, length: int | None = None) -> np.ndarray:
    if not isinstance(value, list) or (length is not None and len(value) != length):
        raise RecordingError(f"{where}: expected {shape_text}, got {str(value)[:60]}")
    if not set(map(type, value)) <= _NUMBER_TYPES:  # JSON numbers only (bool is its own type)
        raise RecordingError(f"{where}: expected {shape_text} of numbers")
    array = np.array(value, dtype=float)
    if not np.isfinite(array).all():
        raise RecordingError(f"{where}: non-finite value")
    return array


def _quaternion(where: str, value) -> np.ndarray:
    q = _numbers(where, value, "[x, y, z, w]", 4)
    norm = math.hypot(*value)
    if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
        raise RecordingError(f"{where}: quaternion norm {norm:.6f} is not 1 (tolerance {QUATERNION_NORM_TOLERANCE})")
    return q / norm


def _number(where: str, value) -> float:
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not np.isfinite(value):
        raise RecordingError(f"{where}: expected a finite number, got {value!r}")
    return float(value)


def _lines(path: Path):
    with open(path, "rb") as raw:
        gzipped = raw.read(2) == b"\x1f\x8b"
    opener = gzip.open if gzipped else open
    try:
        with opener(path, "rt", encoding="utf-8") as text:
            yield from enumerate(text, start=1)
    except (EOFError, OSError, zlib.error, UnicodeDecodeError) as exc:
        raise RecordingError(f"{path}: truncated or unreadable ({exc})") from exc


def _header(path: Path, line: str) -> dict:
    where = f"{path}:1"
    try:
        header = json.loads(line, parse_constant=_refuse_constant)
    except ValueError as exc:
        raise RecordingError(f"{where}: header is not valid JSON ({exc})") from exc
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise RecordingError(f"{where}: not a {FORMAT} file (header 'format')")
    if header.get("version") != VERSION:
        raise RecordingError(f"{where}: unsupported version {header.get('version')!r} (want {VERSION})")
    if header.get("quaternion_order") != "xyzw":
        raise RecordingError(f"{where}: quaternion_order must be 'xyzw', got {header.get('quaternion_order')!r}")
    for key in ("body", "scanner", "laser", "imus"):
        if not isinstance(header.get(key), dict):
            raise RecordingError(f"{where}: header needs an object '{key}'")
    return header


DEMO_RECORDING = "reach-over"
"""The bundled recording the sensor bench replays (the reach-over stress case); the demo's
default is paper 2's experiment 1 (``cobotsafety.app.demo_app.DEFAULT_RECORDING``)."""


def bundled_recording(name: str = DEMO_RECORDING) -> Path:
    """The path of a recording shipped with the package (``assets/recordings/<name>.jsonl.gz``):
    ``exp1``, ``exp2`` (paper 2's experiments) or ``reach-over``."""
    from importlib.resources import files

    return Path(str(files("cobotsafety.assets").joinpath("recordings", f"{name}.jsonl.gz")))


def load_recording(path: str | Path) -> Recording:
    """Read and validate a whole recording; raises ``RecordingError`` naming file and line."""
    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"{path}: no such recording")
    lines = _lines(path)
    try:
        _, first = next(lines)
    except StopIteration:
        raise RecordingError(f"{path}:1: empty file, no header") from None
    header = _header(path, first)
    where = f"{path}:1"
    try:
        body = BodyDimensions.from_dict(header["body"])
    except (KeyError, TypeError, ValueError) as exc:
        raise RecordingError(f"{where}: header 'body': {exc}") from exc
    scanner = {k: _number(f"{where}: scanner.{k}", header["scanner"].get(k)) for k in SCANNER_KEYS}
    laser = {k: _number(f"{where}: laser.{k}", header["laser"].get(k)) for k in LASER_KEYS}
    beams = int(laser["beams"])
    if beams != laser["beams"] or beams < 2 or laser["angle_increment"] == 0 or not 0 <= laser["range_min"] < laser["range_max"]:
        raise RecordingError(f"{where}: inconsistent laser geometry {laser}")
    laser["beams"] = beams
    calibration = {}
    for name, cal in header["imus"].items():
        if not isinstance(cal, dict):
            raise RecordingError(f"{where}: imus.{name} must be an object")
        calibration[name] = (_quaternion(f"{where}: imus.{name}.q_base_imu_init", cal.get("q_base_imu_init")),
                             _quaternion(f"{where}: imus.{name}.q_ref_imu_init", cal.get("q_ref_imu_init")))

    laser_t, laser_r = [], []
    imu_t = {name: [] for name in calibration}
    imu_q = {name: [] for name in calibration}
    last_t = -np.inf
    last_line = 1
    for number, line in lines:
        last_line = number
        where = f"{path}:{number}"
        try:
            record = json.loads(line, parse_constant=_refuse_constant)
        except ValueError as exc:
            raise RecordingError(f"{where}: not valid JSON, truncated? ({exc})") from exc
        if not isinstance(record, dict) or "t" not in record:
            raise RecordingError(f"{where}: a record must be an object with 't'")
        t = _number(f"{where}: t", record["t"])
        if t < last_t:
            raise RecordingError(f"{where}: time goes backwards ({t} s after {last_t} s)")
        last_t = t
        if set(record) == {"t", "laser"}:
            if laser_t and t <= laser_t[-1]:
                raise RecordingError(f"{where}: two laser scans at {t} s")
            ranges = _numbers(f"{where}: laser", record["laser"], f"{beams} ranges", beams)
            if (ranges < 0).any():
                raise RecordingError(f"{where}: negative range")
            laser_t.append(t)
            laser_r.append(ranges)
        elif set(record) == {"t", "imu", "q"}:
            name = record["imu"]
            if name not in calibration:
                raise RecordingError(f"{where}: IMU {name!r} is not in the header's imus {sorted(calibration)}")
            if imu_t[name] and t <= imu_t[name][-1]:
                raise RecordingError(f"{where}: two samples of IMU {name!r} at {t} s")
            imu_q[name].append(_quaternion(f"{where}: q", record["q"]))
            imu_t[name].append(t)
        else:
            raise RecordingError(f"{where}: unknown record keys {sorted(record)}")
    if not laser_t:
        raise RecordingError(f"{path}:{last_line}: missing stream: no laser scan")
    for name in calibration:
        if not imu_t[name]:
            raise RecordingError(f"{path}:{last_line}: missing stream: no sample of IMU {name!r}")
    return Recording(
        body=body,
        scanner=ScannerPose(scanner["x_m"], scanner["y_m"], scanner["yaw_rad"]),
        scanner_height_m=scanner["height_m"],
        laser=laser,
        laser_t_s=np.array(laser_t),
        laser_ranges_m=np.array(laser_r),
        imu_t_s={k: np.array(v) for k, v in imu_t.items()},
        imu_q_ref={k: np.array(v).reshape(-1, 4) for k, v in imu_q.items()},
        calibration=calibration,
        description=str(header.get("description", "")),
        source=str(path),
    )


def _round(values: np.ndarray, decimals: int) -> list:
    return [float(x) for x in np.round(np.asarray(values, dtype=float), decimals)]


def write_recording(path: str | Path, recording: Recording) -> None:
    """Write ``recording`` as gzip JSON Lines (deterministic bytes: gzip mtime 0).

    Times keep 6 decimals, ranges 3 (mm), quaternions 6.
    """
    header = {
        "format": FORMAT, "version": VERSION, "quaternion_order": "xyzw",
        "time_unit": "s", "length_unit": "m", "description": recording.description,
        "body": recording.body.to_dict(),
        "scanner": {"x_m": recording.scanner.x_m, "y_m": recording.scanner.y_m,
                    "yaw_rad": recording.scanner.yaw_rad, "height_m": recording.scanner_height_m},
        "laser": dict(recording.laser),
        "imus": {name: {"q_base_imu_init": _round(init, 6), "q_ref_imu_init": _round(ref, 6)}
                 for name, (init, ref) in recording.calibration.items()},
    }
    records = [(round(float(t), 6), 0, json.dumps({"t": round(float(t), 6), "laser": _round(r, 3)}, separators=(",", ":")))
               for t, r in zip(recording.laser_t_s, recording.laser_ranges_m)]
    for order, name in enumerate(recording.calibration, start=1):
        for t, q in zip(recording.imu_t_s[name], recording.imu_q_ref[name]):
            records.append((round(float(t), 6), order, json.dumps(
                {"t": round(float(t), 6), "imu": name, "q": _round(q, 6)}, separators=(",", ":"))))
    records.sort(key=lambda rec: (rec[0], rec[1]))
    with open(path, "wb") as raw, gzip.GzipFile(fileobj=raw, mode="wb", mtime=0, compresslevel=9) as gz:
        gz.write((json.dumps(header) + "\n").encode())
        gz.write("\n".join(rec[2] for rec in records).encode() + b"\n")
