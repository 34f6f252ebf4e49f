// Keeps fabrica_io non-empty while its parts are added; remove once it has sources.
