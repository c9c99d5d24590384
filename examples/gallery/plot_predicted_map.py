"""
An operating map from the reduced predictor
===========================================

The reduced super-slow predictor with the built-in drift law predicts the behaviour of the free
slider at each operating point in about a millisecond, so a whole map of the paper's grid takes
well under a second (the full simulation of the same map takes minutes).
"""

import beamslider
from beamslider.maps import rows_to_table
from beamslider.superslow import predicted_map

rows = predicted_map(f_ex=range(100, 131, 2), a_ex=range(4, 17, 2), s0=0.3)   # one dict per point
table = rows_to_table(rows)                                                  # columns as arrays
print(len(table["behaviour"]), "points")
fig = beamslider.plot_operating_map(table)
