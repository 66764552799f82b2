"""Earth and Sun constants (EGM2008 / WGS-84 and IERS values), SI units."""

MU_EARTH_M3_S2 = 3.986004418e14     # GM of the Earth (EGM2008)
EARTH_RADIUS_M = 6378137.0          # equatorial radius (WGS-84)
J2 = 1.08262668e-3                  # second zonal harmonic (EGM2008, unnormalised)
EARTH_RATE_RAD_S = 7.292115e-5      # Earth rotation rate (IERS)
AU_M = 1.495978707e11               # astronomical unit
SOLAR_PRESSURE_1AU_N_M2 = 4.56e-6   # solar radiation pressure at 1 AU on an absorbing surface (1367 W/m^2 / c)
