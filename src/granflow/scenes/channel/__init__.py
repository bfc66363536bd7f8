"""The channel scene: its declaration (SCENE) and everything particular to it."""
from .scene import ChannelScene

SCENE = ChannelScene()
