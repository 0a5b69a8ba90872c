"""The main window's capabilities, one small controller each (issue 26).

Each module holds one QObject-based controller that takes the session (and the workers, page
widgets and callables it needs) in its constructor, owns its page widget's signal connections,
talks to the session's targeter and controller through their public API, and gives the window a
page, a few signals and a few methods. ``app/gui.py``'s ``MainWindow`` builds the frame, composes
the features and runs the redraw. Features never import each other (an import-linter contract
in pyproject.toml): what one needs from another, the window passes as a callable or a signal.
"""
