"""The ``circuitnsds`` command: ``run``, ``info``, ``compare`` (see :mod:`.main`)."""
