"""What every kind of design and every run share, under the problem files and the kinds.

- [`.problems`][pes_ref.synthesis.common.problems]    a training batch, the base class of the paper's problems and
  their fields' checks
- [`.optimizers`][pes_ref.synthesis.common.optimizers]  RMSprop and Adam on the grid values
- [`.plans`][pes_ref.synthesis.common.plans]       how a problem is optimized
  ([`Plan`][pes_ref.synthesis.common.plans.Plan], [`PolishPlan`][pes_ref.synthesis.common.plans.PolishPlan]) and the
  defaults
- [`.resampling`][pes_ref.synthesis.common.resampling]  bilinear resampling of a grid between coarse-to-fine stages
- [`.validation`][pes_ref.synthesis.common.validation]  a grid judged on fixed validation particles, and the best kept
- [`.exits`][pes_ref.synthesis.common.exits]       where a particle leaves the domain, and eq. (5) charged there
- [`.level_set`][pes_ref.synthesis.common.level_set]   a design realizable as designed: the grid values a level set
"""
