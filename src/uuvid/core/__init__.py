"""The ground floor every other room stands on: SI units and the papers' unit conversions
(``units``), one time-series type (``response.TimeResponse``) and its metrics (``metrics``), one
result surface (``result.Result``: summary / to_dict / plot / report), figures (``plots``),
self-contained HTML pages (``html``), progress bars (``progress``), atomic writes (``atomic``),
the on-disk cache (``cache``) and one BLAS thread for small dense problems (``threads``).
Nothing here imports from another room of the package."""
