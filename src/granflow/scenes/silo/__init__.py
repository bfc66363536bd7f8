"""The silo scene: its declaration (SCENE) and everything particular to it."""
from .scene import SiloScene

SCENE = SiloScene()
