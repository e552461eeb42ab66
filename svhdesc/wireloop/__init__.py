"""The wire-and-loop Q-learning planner of the thesis' Appendix A (and its run on the UR5 + SVH in MuJoCo)."""
