"""What users look at: headless figures (``plots``, ``mission``), self-contained HTML pages
(``html``) and progress bars on stderr (``progress``)."""
