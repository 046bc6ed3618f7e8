"""C sources of the FMUs and of the host hysteresis kernel (shipped as package data)."""
from pathlib import Path

SOURCE_DIR = Path(__file__).resolve().parent
