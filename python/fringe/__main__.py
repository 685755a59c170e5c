"""``python -m fringe``: what the package is and where it reads from."""

import fringe

print(f"fringe {fringe.__version__}: runs of layout {fringe.LAYOUT_VERSION} and older")
