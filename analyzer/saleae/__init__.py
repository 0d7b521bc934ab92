"""Saleae Logic 2 jobs (docs/instruments.md, "The Saleae analyzer"): the High
Level Analyzer ``Gimbal``, generated from the command table (``extension``),
and its installation as an extension folder (``install``)."""
