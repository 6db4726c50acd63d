"""A recording read back: write a rerun recording (.rrd) of one run, then read it as a
pandas DataFrame, one column per signal, indexed by time (docs/tracing.md). Open the file
in the viewer with `rerun theta1_step.rrd` (no display: `rerun --serve-web FILE`).

    python examples/04_recording.py
"""

import twolink
from twolink.tracing import read_recording, write_recording

scenario = twolink.load_scenario("paper/theta1_step")
trajectory = twolink.run_scenario(scenario)
# one run under the prefix "ctc", every 10th sample of the 1 kHz loop (100 Hz)
write_recording("theta1_step.rrd", [("ctc", trajectory, scenario.arm, {"every": 10})])
frame = read_recording("theta1_step.rrd")
print(frame.index.name, len(frame), "samples;", len(frame.columns), "columns, e.g.:")
print(frame[["ctc/joint1_angle_rad", "ctc/joint1_torque_Nm"]].describe().loc[["min", "max"]])
assert abs(frame["ctc/joint1_angle_rad"].iloc[-1] - trajectory.q[-1, 0]) < 1e-3
