"""fleetnav's shipped data (robots, worlds, models, textures, missions, challenges, Zenoh configs, the Foxglove
layout). Not code: a package only so the wheel carries these files and importlib.resources finds them
from any working directory (sim.resources is the one place that looks them up)."""
