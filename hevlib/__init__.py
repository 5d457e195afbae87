"""hev-sizing: size a power-split hybrid conversion of a conventional car.

All logic lives in this package; ``stages/`` holds thin typer commands only.
"""

__version__ = "0.1.0"
#: Bumped whenever the simulator's physics change: stored with every simulated artifact.
MODEL_VERSION = "sim-1"
