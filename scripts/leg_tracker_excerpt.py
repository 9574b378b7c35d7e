"""Write the excerpt of the leg_tracker bags that the tests use on a fresh clone.

``python scripts/leg_tracker_excerpt.py [--data ../shared/data/leg_tracker] [--out tests/data/leg_tracker]``

The full bags (``../shared/data/leg_tracker``, BSD-3, angusleigh/leg_tracker) are not in the
repository; ``tests/conftest.py`` falls back to this excerpt when they are absent. Messages
are copied byte for byte (no re-serialisation) into bz2-compressed ROS1 bags of the same names:

* ``positive_1_extracted.bag``, ``positive_2_extracted.bag``: every scan and label (the
  held-out recall tests need all 440 labelled legs); their RViz marker topic is left out;
* ``negative_2.bag``: every ``NEGATIVE_STEP``-th scan of each scanner (the scans training
  uses, ``train_legs.NEGATIVE_SCAN_STEP``; consecutive scans are near duplicates);
* ``demo_stationary_simple_environment.bag``: the first ``DEMO_SCANS`` scans (40 s of people
  walking past).
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

from rosbags.rosbag1 import Reader, Writer

REPO = Path(__file__).resolve().parents[1]
NEGATIVE_STEP = 4
DEMO_SCANS = 400
#: name -> (topics kept or None for all, keep(index of the message on its topic) -> bool)
EXCERPTS = {
    "positive_1_extracted.bag": ({"/training_scan", "/leg_cluster_positions"}, lambda k: True),
    "positive_2_extracted.bag": ({"/training_scan", "/leg_cluster_positions"}, lambda k: True),
    "negative_2.bag": (None, lambda k: k % NEGATIVE_STEP == 0),
    "demo_stationary_simple_environment.bag": (None, lambda k: k < DEMO_SCANS),
}


def copy_bag(source: Path, target: Path, topics: set[str] | None, keep) -> int:
    """Copy the messages of ``topics`` (all when None) whose per-topic index passes ``keep``;
    returns how many were written."""
    target.unlink(missing_ok=True)
    written = 0
    with Reader(source) as reader:
        connections = [c for c in reader.connections if topics is None or c.topic in topics]
        writer = Writer(target)
        writer.set_compression(Writer.CompressionFormat.BZ2)
        with writer:
            out = {c.id: writer.add_connection(c.topic, c.msgtype, msgdef=c.msgdef.data, md5sum=c.digest,
                                               callerid=c.ext.callerid, latching=c.ext.latching)
                   for c in connections}
            index: dict[str, int] = {}
            for connection, timestamp, raw in reader.messages(connections=connections):
                k = index.get(connection.topic, 0)
                index[connection.topic] = k + 1
                if keep(k):
                    writer.write(out[connection.id], timestamp, raw)
                    written += 1
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data" / "leg_tracker")
    parser.add_argument("--out", type=Path, default=REPO / "tests" / "data" / "leg_tracker")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(args.data / "LICENSE", args.out / "LICENSE")
    for name, (topics, keep) in EXCERPTS.items():
        count = copy_bag(args.data / name, args.out / name, topics, keep)
        print(f"{name}: {count} messages, {(args.out / name).stat().st_size / 1e3:.0f} kB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
