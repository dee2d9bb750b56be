"""Code generation: kernels (CSE), Jinja templates, render / write / check."""
