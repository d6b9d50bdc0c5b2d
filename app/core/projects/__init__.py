"""Projects: the studio's work in one `.bstudio` file (a zip with a versioned manifest), and
the rotating autosaves. Pure computation and files; the studio's ProjectSession drives it."""
