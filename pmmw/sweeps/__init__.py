"""`pmmw sweep`: trade studies over scenario parameters.

`spec` (the sweep file and ``--grid``: axes, zipped lists, variants), `run` (the executors and
``sweep.csv``), `report` (the trade-study report: plots, heat maps, contact sheet, GIFs).
"""
