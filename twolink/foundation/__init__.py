"""The foundation: modules that import nothing of twolink outside this package. References (time
functions of the targets), output folders (ownership, locks, seals, atomic writes),
Ctrl-C and SIGTERM handling, process-pool and Dask executors, the key merging
of scenario files, and the shipped files as package data (``shipped``). Every other
layer may build on these."""
