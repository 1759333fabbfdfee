// Replaced by the renderer sources; keeps the library target valid meanwhile.
