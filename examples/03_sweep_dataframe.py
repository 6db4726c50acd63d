"""A sweep read as a DataFrame: the shipped robustness sweep on 8 plants (each of its five
controllers on each plant), one row per (plant, controller); then its results read back
from the folder it wrote (sweep_out/) with twolink.load_results.

    python examples/03_sweep_dataframe.py
"""

import twolink

table = twolink.run_sweep("sweeps/robustness", "sweep_out", samples=8, workers=1)
print(table.shape, "rows x columns;", sorted(table.controller.unique()))
print(table.groupby("controller")[["joint1_iae_rad_s", "joint1_torque_peak_Nm"]].median())
again = twolink.load_results("sweep_out")  # the same table, from results.parquet
print("read back:", again.shape, "equal:", again.equals(table))
print("plants that met the spec:", table.groupby("controller").outcome.value_counts().to_dict())
