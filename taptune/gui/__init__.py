"""The desktop app (PySide6): views and workers that call the same functions as the CLI.

Modules: ``app`` (start, screenshots), ``main_window`` (the session and the workflow),
``assembly_panel``/``assembly_drawing`` (holder, tool, stick-out), ``recorder_panel``
(live taps), ``spectrum_view`` (labelled peaks, click to relabel), ``fit_view``,
``predictor``, ``library_view``, ``workers`` (QThread tasks), ``plotting``, ``messages``.
Nothing here is imported on the ``taptune --help`` path.
"""
