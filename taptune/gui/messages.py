"""Messages to the user and careful file writes: every failure becomes a dialog, never a crash.

Dialogs are opened without blocking (``QMessageBox.open``), so background work, the
level meter and the tests keep running while one is shown. Every message is also kept
in :data:`history` (title, text) for the status bar and the tests.
"""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QMessageBox, QWidget

history: list[tuple[str, str]] = []


def show_error(parent: QWidget | None, title: str, text: str) -> QMessageBox:
    """A warning dialog that does not block; returns it."""
    return _show(parent, QMessageBox.Warning, title, text)


def show_info(parent: QWidget | None, title: str, text: str) -> QMessageBox:
    """An information dialog that does not block; returns it."""
    return _show(parent, QMessageBox.Information, title, text)


def _show(parent, icon, title: str, text: str) -> QMessageBox:
    history.append((title, text))
    box = QMessageBox(icon, title, text, QMessageBox.Ok, parent)
    box.setAttribute(Qt.WA_DeleteOnClose)
    box.setTextInteractionFlags(Qt.TextSelectableByMouse)
    box.open()
    return box


def save_text(parent: QWidget | None, path, text: str) -> bool:
    """Write ``text`` to ``path`` atomically (:mod:`taptune.io.atomic`); a dialog says why if it fails."""
    from taptune.io.atomic import atomic_write_bytes

    path = Path(path)
    try:
        atomic_write_bytes(path, text.encode("utf-8"))
    except OSError as err:
        show_error(parent, "Cannot save", f"{path}: {err.strerror or err}")
        return False
    return True
