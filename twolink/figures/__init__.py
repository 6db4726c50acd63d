"""Figures of finished results (matplotlib, headless): the only package that draws.
It sits above the simulation and below the sweeps and studies that save figures."""
