"""taptune: tool-holder dynamics from the sound of a tap.

Layers (data flows one way, no module imports a layer above it)::

    io -> signal -> model -> identify -> library -> report / cli / gui
"""

__version__ = "0.1.0"
