"""The reproduction: its manifest, its runs and their folders, the report and its figures."""
