//! Recording folders (CONTRACT.md, "Recording"): one sub-folder of PNG frames per camera.
