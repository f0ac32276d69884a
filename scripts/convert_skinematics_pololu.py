"""Convert scikit-kinematics' Pololu recording into a nodesim replay log.

Usage:
    python scripts/convert_skinematics_pololu.py PATH/TO/data_polulu.txt OUT.csv

Where the file comes from: ``pip download --no-deps scikit-kinematics==0.10.4`` gives a wheel whose
``tests/data/data_polulu.txt`` is the recording (BSD licence, Copyright (C) 2016 Thomas Haslwanter; the
licence travels with the converted file in its header ``source`` and in tests/data/replay/LICENSE-skinematics.txt).
The conversion itself (units, axes, the gyro sensitivity) is documented in nodesim.replay.convert.
"""

import sys

from nodesim.replay.convert import pololu_recording
from nodesim.replay.recorder import write_log


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    node, meta = pololu_recording(argv[0])
    write_log(argv[1], [node], meta)
    print(f"wrote {argv[1]}: {node.columns['t_s'].size} samples")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
