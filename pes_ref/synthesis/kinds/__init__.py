"""The kinds of design: the paper's funnel and oscillator, one module each, and the registry that
serves them and a problem file's design through one interface.

- [`.gait`][pes_ref.synthesis.kinds.gait]        the oscillator's prescribed-gait shooting cost and its starts
- [`.envelope`][pes_ref.synthesis.kinds.envelope]    a realizable funnel's default start, made by design
- [`.funnel`][pes_ref.synthesis.kinds.funnel]      the funnel (Figs. 6-7)
- [`.oscillator`][pes_ref.synthesis.kinds.oscillator]  the oscillator (Figs. 8-11)
- [`.escapement`][pes_ref.synthesis.kinds.escapement]  the hand-drawn escapement surface, a reference for the
  oscillator
- [`.analysis`][pes_ref.synthesis.kinds.analysis]    held-out particles, cycle figures, each kind's figures and panels
- [`.registry`][pes_ref.synthesis.kinds.registry]    the kinds of design as one interface (`KINDS`) and
  [`evaluate`][pes_ref.synthesis.kinds.registry.evaluate] for every kind
- [`.plots`][pes_ref.synthesis.kinds.plots]       held-out paths drawn on a design's surface (``evaluate --plot``;
  matplotlib imported when it draws)
"""
