"""Input shaping: impulse sequences that cancel the residual vibration of lightly damped modes
(Singer & Seering 1990), and their sensitivity curves ([Slew and settle](docs/theory/slew-and-settle.md))."""
