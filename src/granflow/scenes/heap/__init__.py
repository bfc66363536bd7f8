"""The heap scene: its declaration (SCENE) and everything particular to it."""
from .scene import HeapScene

SCENE = HeapScene()
