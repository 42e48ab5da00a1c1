"""To-scale side view of a tool in its holder, with the contact zone and the stick-out."""

from __future__ import annotations

from PySide6.QtCore import QPointF, QRectF, QSize, Qt
from PySide6.QtGui import QBrush, QColor, QFont, QPainter, QPen
from PySide6.QtWidgets import QSizePolicy, QWidget

HOLDER = QColor("#a9b4bf")
BORE = QColor("#eef1f4")
TOOL = QColor("#4f5b66")
FLUTES = QColor("#6d7a87")
CONTACT = QColor(230, 126, 34, 150)
DIMENSION = QColor("#1f4e79")
MM = 1e-3


class AssemblyDrawing(QWidget):
    """Section of holder and tool drawn with one scale for both axes.

    The holder is shown in section (outer contour filled, bore lighter), the tool on
    top of it, the contact zone (docs/physics.md, §1) as an orange band, and the stick-out and
    contact lengths as dimension lines, so a wrong number in the form is seen at once.
    """

    def __init__(self, parent=None):
        super().__init__(parent)
        self._assembly = None
        self._message = "no assembly"
        self.setMinimumHeight(120)
        self.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Preferred)
        self.setToolTip("To scale: holder in section (grey), tool (dark), contact zone (orange)")

    def sizeHint(self) -> QSize:
        return QSize(380, 150)

    def set_assembly(self, assembly, message: str = "") -> None:
        """Show ``assembly`` (or ``message`` where it is None)."""
        self._assembly = assembly
        self._message = message or "no assembly"
        self.update()

    def paintEvent(self, event) -> None:
        p = QPainter(self)
        p.setRenderHint(QPainter.Antialiasing)
        p.fillRect(self.rect(), QColor("white"))
        if self._assembly is None:
            p.setPen(QColor("#888888"))
            p.drawText(self.rect(), Qt.AlignCenter | Qt.TextWordWrap, self._message)
            return
        self._draw(p, self._assembly)

    def _draw(self, p: QPainter, asm) -> None:
        font = QFont(self.font())
        font.setPointSizeF(max(7.0, font.pointSizeF() * 0.9))
        p.setFont(font)
        text_h = p.fontMetrics().height()
        margin = 8
        holder_len = asm.holder.length
        length = asm.z_tip
        max_od = max(s.od for s in asm.holder.segments)
        # Room below the part for two dimension lines with their labels.
        avail_w = self.width() - 2 * margin
        avail_h = self.height() - 2 * margin - 2 * (text_h + 6)
        scale = min(avail_w / length, avail_h / max_od)  # pixels per metre, both axes
        x0 = margin + (avail_w - scale * length) / 2
        y_axis = margin + scale * max_od / 2

        def rect(z0, z1, d):
            return QRectF(x0 + z0 * scale, y_axis - d * scale / 2, (z1 - z0) * scale, d * scale)

        p.setPen(QPen(QColor("#6b7785"), 1))
        z = 0.0
        for s in asm.holder.segments:
            p.setBrush(QBrush(HOLDER))
            p.drawRect(rect(z, z + s.length, s.od))
            if s.id > 0:
                p.setBrush(QBrush(BORE))
                p.drawRect(rect(z, z + s.length, s.id))
            z += s.length
        z = asm.z_tool_start
        last = len(asm.tool.segments) - 1
        for i, s in enumerate(asm.tool.segments):
            p.setBrush(QBrush(FLUTES if (i == last and last > 0) else TOOL))
            p.drawRect(rect(z, z + s.length, s.od))
            z += s.length
        zc0 = asm.z_contact_start
        d_contact = asm.tool_diameter_at(holder_len - 1e-6) or asm.tool.segments[0].od
        p.setPen(Qt.NoPen)
        p.setBrush(QBrush(CONTACT))
        p.drawRect(rect(zc0, holder_len, d_contact * 1.15))
        # Centre line.
        p.setPen(QPen(QColor("#888888"), 1, Qt.DashDotLine))
        p.drawLine(QPointF(x0 - 4, y_axis), QPointF(x0 + length * scale + 4, y_axis))

        y1 = y_axis + scale * max_od / 2 + text_h / 2 + 4
        self._dimension(p, x0 + holder_len * scale, x0 + length * scale, y1,
                        f"stick-out {asm.stickout / MM:.1f} mm")
        self._dimension(p, x0 + zc0 * scale, x0 + holder_len * scale, y1 + text_h + 6,
                        f"contact {asm.contact_length / MM:.1f} mm", color=QColor("#b35900"))

    def _dimension(self, p: QPainter, xa: float, xb: float, y: float, label: str, color: QColor = DIMENSION) -> None:
        """A dimension line from xa to xb at height y with its label beside or above it."""
        p.setPen(QPen(color, 1.2))
        p.drawLine(QPointF(xa, y), QPointF(xb, y))
        for x, sign in ((xa, 1), (xb, -1)):
            p.drawLine(QPointF(x, y), QPointF(x + 5 * sign, y - 3))
            p.drawLine(QPointF(x, y), QPointF(x + 5 * sign, y + 3))
            p.drawLine(QPointF(x, y - 5), QPointF(x, y + 5))
        metrics = p.fontMetrics()
        w = metrics.horizontalAdvance(label)
        h = metrics.height()
        # Beside the line on the left where it is too short for the text.
        if w + 8 < xb - xa:
            x_text = (xa + xb) / 2 - w / 2
            box = QRectF(x_text - 2, y - h / 2, w + 4, h)
            p.fillRect(box, QColor("white"))
        else:
            x_text = xa - w - 8
            box = QRectF(x_text - 2, y - h / 2, w + 4, h)
        p.drawText(box, Qt.AlignCenter, label)
