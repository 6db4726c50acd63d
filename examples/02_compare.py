"""A comparison: FCM-CTC against CTC on the shipped raw θ1 step, plant by plant on 10
plants drawn as the robustness sweep draws them (masses, lengths, gravity, a payload the
controllers do not know). It prints the paired table with its verdicts ("better": FCM-CTC
lower beyond the practical tolerance; docs/compare.md) and writes compare.png here.

    python examples/02_compare.py
"""

import twolink

result = twolink.compare("theta1_step", "FCM-CTC", "CTC", plants=10)  # writes nothing
print(result)  # the table, as `twolink compare theta1_step FCM-CTC CTC -n 10` prints it
print(result.claims[["metric", "better", "worse", "verdict"]])  # a pandas DataFrame
result.figure.savefig("compare.png")  # every plant's θ1, and FCM-CTC − CTC below
print("figure: compare.png")
