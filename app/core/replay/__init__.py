"""A replay for collaborators: the frames of a motion with its ghosts, traces and a title card
(`scene`), the self-contained folder that plays it in any browser (`folder`), and a reader of
viser's `.viser` recordings (`viser_file`). Recording itself needs viser: app/replay_recorder.py.
"""
