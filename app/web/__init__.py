"""The studio's web server layer: who may connect (`access`), viser's request hook
(`hook`), bounded uploads (`upload_limits`), and the one entry point (`guard`).

Kept import-light: `app.web.access` has no viser import, so the CLI and the config can
use it without starting the GUI stack.
"""
