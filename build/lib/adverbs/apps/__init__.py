"""Applications on top of the library: the ``adverbs`` command line and the evaluation of verbs."""
