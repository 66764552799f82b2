"""The orbit a free-flying system flies: elements or a TLE, two-body + J2 propagation, the
ECI and LVLH frames, the Sun's direction and the Earth's cylindrical shadow
(docs/theory/environment.md). Nothing here depends on the attitude: the orbit is integrated
on its own fixed grid and read by the attitude loop at any time by interpolation."""
