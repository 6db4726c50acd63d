"""One run: the shipped θ1 step (a 2 s quintic move of 1 rad) under computed torque, its
step metrics and a figure. Run it from any folder: it writes theta1_step.png there.

    python examples/01_one_run.py
"""

import twolink

scenario = twolink.load_scenario("paper/theta1_step")  # a shipped scenario, by its name
trajectory = twolink.run_scenario(scenario)  # MuJoCo at 1 kHz, the scenario's CTC
metrics = twolink.measure(scenario, trajectory)
print(metrics)  # every metric of both joints (undefined ones as "—")
m = metrics.step[0]  # joint 1's step metrics
print(f"θ1: rise {m.rise_time:.3f} s, settling {m.settling_time:.3f} s, Mp {m.overshoot:.2f} %")
twolink.run_figures(trajectory, scenario.name)["angles"].savefig("theta1_step.png")
print("figure: theta1_step.png")
