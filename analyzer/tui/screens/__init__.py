"""The TUI's screens, one a module: the main screen (capture.py) and the full
screens over it, statistics (stats.py), plots (plots.py), the doctor's
findings (findings.py) and help (help.py). The app imports a full screen when
its key is first pressed."""
