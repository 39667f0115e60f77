"""Unit conversions used at the edges (lab files and reports are in inch, lbf, psi).

Inside batlab everything is SI. The paper's mass density is weight density / g with
g = 386.089 in/s^2 = 9.80665 m/s^2 (standard gravity).
"""

IN_TO_M = 0.0254
LBF_TO_N = 4.4482216152605
G0_M_S2 = 9.80665
PSI_TO_PA = LBF_TO_N / IN_TO_M**2
LB_TO_KG = LBF_TO_N / G0_M_S2
LBF_IN3_TO_KG_M3 = LBF_TO_N / IN_TO_M**3 / G0_M_S2
"""Weight density lbf/in^3 -> mass density kg/m^3."""
KG_M2_TO_LB_IN2 = 1.0 / (LB_TO_KG * IN_TO_M**2)


def m_to_in(x_m):
    """Convert metres to inches."""
    return x_m / IN_TO_M
