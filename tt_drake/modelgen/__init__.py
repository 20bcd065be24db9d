"""Writers for the model files in ``models/``, generated from :mod:`tt_drake.constants`.

Regenerate every file with ``python -m tt_drake.modelgen``; tests check the committed files match.
"""
