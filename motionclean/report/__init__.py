"""Reports of a cleaning: figures (:mod:`.metrics`, :mod:`.world`), the report dictionary and
terminal table (:mod:`.summary`, the JSON schema), and the self-contained HTML page
(:mod:`.html`, :mod:`.html_world`, :mod:`.traces`).

Reports read clips and the step registry (how each step's notes read); they never import a
step module, the commands or the job runners.
"""
