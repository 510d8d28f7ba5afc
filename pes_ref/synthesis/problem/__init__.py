"""The problem-file format: a design problem stated by a TOML file (``docs/problems.md``).

- [`.file_keys`][pes_ref.synthesis.problem.file_keys]   the keys of a problem file: types, defaults, units, and their
  reader
- [`.objective_terms`][pes_ref.synthesis.problem.objective_terms] the objective terms (registry kind -> class)
- [`.success`][pes_ref.synthesis.problem.success]     the per-particle success tests (registry kind -> class), each
  with its surrogate
- [`.surrogates`][pes_ref.synthesis.problem.surrogates]  the objective a problem without ``[[objective]]`` derives from
  its success tests
- [`.problem_contact`][pes_ref.synthesis.problem.problem_contact] ``[surface.contact]``: eq. (1)'s parameters and a
  realizable design's starting shapes
- [`.design_problem`][pes_ref.synthesis.problem.design_problem] the problem a file states
  ([`DesignProblem`][pes_ref.synthesis.problem.design_problem.DesignProblem])
- [`.problem_file`][pes_ref.synthesis.problem.problem_file] problem files: reading, checking, changing keys, writing;
  the shipped ones (``pes_ref/synthesis/data/``)
"""
