"""CasADi -> C code generation and loading (:mod:`.codegen`, disk cache in
``$MMPLAN_CACHE`` or ``$TMPDIR/mmplan-codegen``) and the per-process model cache
(:mod:`.model_cache`)."""

from mmplan.compile.codegen import compile_function, compiler
from mmplan.compile.model_cache import ModelCache

__all__ = ["ModelCache", "compile_function", "compiler"]
