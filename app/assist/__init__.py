"""The assistive view's features, one module each; ``app.assist_window.AssistWindow`` composes them.

- ``settings``: ``AssistSettings`` (``assist.toml``) and the switches' names and words — shared by all;
- ``arm_chain``: the loop on its thread (``AssistWorker``), the driven arm, the images (``ArmChain``);
- ``modes``: the mode buttons, the scan period and the choosing they drive (``ChoiceModes``);
- ``switches``: keys, mouse, gamepad and GPIO switches, holds and X11 auto-repeat (``SwitchInput``);
- ``settings_dialog``: "Switches…" (``SwitchSettingsEditor``, ``SwitchSettingsDialog``);
- ``sound``: the highlight's sound cue (``HighlightSound``);
- ``menu``: the ☰ menu and Ctrl+Q (``AssistMenu``);
- ``screens``: filling the screen, ``--screenshot``.

A feature imports ``settings``, ``core`` and ``widgets``, never another feature: the window passes
callables and connects signals. What is not about Qt lives in ``core.motion`` (``scanning``,
``switch_presses``, ``assist_loop.state_line``).
"""
