"""Studies built on the public API and the scenes: order convergence (``convergence``),
speed (``bench``) and where the methods fail (``stability``); ``common`` holds what they
share (CSV, tables, failures, progress)."""
