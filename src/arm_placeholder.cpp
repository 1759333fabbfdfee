// Replaced by the arm-planning sources; keeps the library target valid meanwhile.
