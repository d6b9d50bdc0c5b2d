"""The studio layer: a small shared state with change signals (state.py), one session per
feature owning its panel and overlays (*_session.py), and the server object (server.py)."""

from app.studio.server import Studio

__all__ = ["Studio"]
