"""A MATLAB Fuzzy Logic Toolbox file (.fis) as the fuzzy term of computed torque: a small
Mamdani PD written as the Toolbox writes it (Gaussian membership functions, 3 x 3 rules),
read with twolink.read_fis, evaluated, then used as FCM-CTC's fuzzy term and run beside
plain CTC on a raw step with model error. Writes my_pd.fis here (docs/fuzzy.md, "Any MATLAB FIS").

    python examples/05_matlab_fis.py
"""

import numpy as np

import twolink

FIS = """[System]
Name='my_pd'
Type='mamdani'
NumInputs=2
NumOutputs=1
NumRules=9
AndMethod='min'
OrMethod='max'
ImpMethod='min'
AggMethod='max'
DefuzzMethod='centroid'

[Input1]
Name='error'
Range=[-1 1]
NumMFs=3
MF1='N':'gaussmf',[0.4 -1]
MF2='Z':'gaussmf',[0.4 0]
MF3='P':'gaussmf',[0.4 1]

[Input2]
Name='rate'
Range=[-1 1]
NumMFs=3
MF1='N':'gaussmf',[0.4 -1]
MF2='Z':'gaussmf',[0.4 0]
MF3='P':'gaussmf',[0.4 1]

[Output1]
Name='u'
Range=[-1 1]
NumMFs=3
MF1='N':'trimf',[-2 -1 0]
MF2='Z':'trimf',[-1 0 1]
MF3='P':'trimf',[0 1 2]

[Rules]
1 1, 1 (1) : 1
1 2, 1 (1) : 1
1 3, 2 (1) : 1
2 1, 1 (1) : 1
2 2, 2 (1) : 1
2 3, 3 (1) : 1
3 1, 2 (1) : 1
3 2, 3 (1) : 1
3 3, 3 (1) : 1
"""

with open("my_pd.fis", "w") as f:
    f.write(FIS)
fis = twolink.read_fis("my_pd.fis")
grid = np.array([[-0.5, 0.0], [0.0, 0.0], [0.3, 0.2]])  # (n, inputs): (error, rate)
print("F(e, ė) on", grid.tolist(), "=", fis.evaluate(grid).ravel().round(4).tolist())

# The paper's raw 1 rad step of θ1 at ωn = 3 rad/s (the gains at which the torque limits
# allow raw steps; the shipped design's 60 / 15 N·m), the plant's second link 20 % heavier
# than the controllers' model: where the fuzzy term acts.
model, plant = twolink.ArmParams(), twolink.ArmParams(m2=1.2)
move = twolink.ArmReference(twolink.Step(final=1.0), twolink.Step(final=0.0))
runs = {
    "CTC": twolink.ComputedTorque(model, move, kp=9.0, kd=6.0),
    "my_pd.fis": twolink.FuzzyComputedTorque.fcm(model, move, "my_pd.fis", kp=9.0, kd=6.0),
}
for name, controller in runs.items():
    trajectory = twolink.simulate(twolink.Plant.build(plant), controller, duration=4.0)
    m = twolink.step_metrics(trajectory.t, trajectory.q[:, 0], target=1.0)
    print(f"{name:10s} θ1: rise {m.rise_time:.3f} s, Mp {m.overshoot:.2f} %, "
          f"final error {trajectory.e[-1, 0]:+.4f} rad")  # fmt: skip
