"""Flexible appendages and propellant slosh on any free bus (the `model.appendages:` block).

- params.py       the block: wings of hinged panels, spring-mass and pendulum slosh models
- build.py        adds them to a bus through MjSpec (bodies, hinges, slides, springs, dampers, stops)
- joints.py       finds them in a compiled model: coordinates, trace signals, hinges the 3D view turns
- closed_form.py  the planar modes of bus + panels, clamped and free-free; slosh frequencies
- modal.py        the modes MuJoCo gives: linearised (mjd_transitionFD) and from a free decay

Theory and measured agreement: docs/theory/flexible.md.
"""
