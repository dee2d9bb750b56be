"""The inputs resolver: a model and parameter values -> the generated kernels' inputs.

The first stage of an evaluation (:class:`~eigentwist.runtime.evaluator.Evaluator` holds one as
``ev.resolver``): a model (a preset such as ``"paper"`` or a list of effects, ``EFFECT@N`` for
one leg) and parameter values (SI units; scalars or (N,) arrays; ``NAME@N`` for leg N's own
value) become the one input dict the generated NumPy and C kernels read: every parameter (the
description's default unless given), each effect's switch ``on_<effect>`` (``on_<effect>__N``
per leg for a leg-level effect) and each leg's copy ``P__N`` of a leg-level parameter. Values
are checked against their bounds and the description's constraints; unknown names and wrong
shapes raise :class:`~eigentwist.runtime.errors.InputError` naming the value.
"""

from __future__ import annotations

import numpy as np

from ..description import RobotDescription
from ..description.effects import base_name, leg_input_name, leg_switch_name, resolve_model, split_scope, switch_name
from ..description.names import did_you_mean
from . import condense
from .constraints import check_constraints, compile_constraints
from .errors import InputError
from .memo import BoundedMemo

__all__ = ["InputResolver"]

_NUMBERS = (float, int, np.float64, np.float32, np.int64, np.int32)
#: an effect's switch on and off (read-only: the C pass packs them once)
_ON, _OFF = np.array(1.0), np.array(0.0)
_ON.flags.writeable = _OFF.flags.writeable = False


class InputResolver:
    """Model and parameter values of one robot -> the generated code's input dict.

    Remembers per robot what does not change between calls: a model's effects, the layout of
    the inputs per (model, names given), and the resolved inputs per (model, scalar values),
    so that a repeated call gets the same read-only 0-d arrays (which the C pass packs once,
    :mod:`.c_kernels`)."""

    def __init__(self, robot: RobotDescription):
        self.robot = robot
        #: parameter name -> :class:`~eigentwist.description.parameters.Parameter`
        self.parameters = {p.name: p for p in robot.parameters}
        #: the description's effects, by name
        self.effects = robot.effects
        self.n_legs = len(robot.legs)
        #: parameter name -> the leg-level effect that owns it (these take ``NAME@N``)
        self.leg_parameters = {
            q.name: e for e in robot.effects if robot.effect(e).leg_level for q in robot.effect(e).params
        }
        self.constraints = compile_constraints(robot)
        self._effect = {e: robot.effect(e) for e in robot.effects}
        self._checked_defaults: set = set()  # parameters whose default has been checked (resolve_in_full)
        self._resolved: dict = {}  # model spec -> resolve_model's effects (model_effects)
        self._memo: dict = {}  # (model, scalar values) -> resolved inputs (resolve)
        #: (model, names given) -> where the defaults and values go (laid_out); a diagnosis tries a few hundred models
        self._layouts = BoundedMemo(512)
        self._defaults: dict = {}  # parameter -> (default, read-only 0-d array): default
        self._kinds: dict = {}  # (question, effects) -> answer (remembered)

    def model_effects(self, model) -> tuple:
        """``resolve_model(model, self.robot)``, remembered per (hashable) model spec."""
        try:
            return self._resolved[model]
        except (KeyError, TypeError):
            effects = resolve_model(model, self.robot)
        try:
            self._resolved[model] = effects
        except TypeError:  # an unhashable spec (a list of names)
            pass
        return effects

    def parameter(self, name: str):
        """The :class:`Parameter` ``name``; ``NAME@N`` gives leg N's copy (same unit, bounds)."""
        if name in self.parameters:
            return self.parameters[name]
        if not self.accepts(name):
            self.scoped({name: 0.0})  # raises the one-line error
        return self.parameters[name.partition("@")[0]].with_values(name=name)

    def accepts(self, name: str) -> bool:
        """True when ``name`` is a parameter, or ``NAME@N`` of a leg-level one with N a leg."""
        if name in self.parameters:
            return True
        try:
            self.scoped({name: 0.0})
        except InputError:
            return False
        return True

    def scoped(self, params: dict) -> dict:
        """``{"eta_a@3": v}`` -> ``{("eta_a", 3): v}``; unknown names raise one line."""
        scoped, unknown = {}, []
        for key, value in params.items():
            if key in self.parameters:
                continue
            name, at, _ = key.partition("@")
            if not at or name not in self.parameters:
                unknown.append(key)
                continue
            if name not in self.leg_parameters:
                raise InputError(
                    f"parameter {key!r}: {name} belongs to no leg-level effect, so it has no per-leg "
                    f"value (leg-level parameters: {', '.join(self.leg_parameters) or 'none'})"
                )
            try:
                scoped[split_scope(key, self.n_legs, "parameter")] = value
            except ValueError as exc:
                raise InputError(str(exc)) from None
        if unknown:
            raise InputError(
                f"unknown parameter(s) {', '.join(map(repr, unknown))} for {self.robot.name}"
                f"{did_you_mean(unknown[0].partition('@')[0], self.parameters)}: "
                f"expected names from {', '.join(self.parameters)} (NAME@N for one leg)"
            )
        return scoped

    def array(self, name: str, value, n: int, check: bool) -> np.ndarray:
        """``value`` of parameter ``name`` (``NAME@N`` for a leg's own) as a float array: a
        scalar or (n,) for n poses, else InputError naming the shape; checked against the
        parameter's bounds where ``check``."""
        arr = np.asarray(value, dtype=float)
        if arr.ndim > 1 or (arr.ndim == 1 and arr.shape[0] not in (1, n)):
            raise InputError(f"parameter {name!r} has shape {arr.shape}: expected a scalar or ({n},) for {n} poses")
        if check:
            try:
                self.parameters[name.partition("@")[0]].check(arr)
            except ValueError as exc:
                raise InputError(
                    str(exc).replace(f"parameter {name.partition('@')[0]!r}", f"parameter {name!r}")
                ) from None
        return arr

    def resolve(self, n: int, params: dict, model) -> dict:
        """The generated code's inputs: parameters, effect switches and each leg's copies.

        Scalar values are resolved once per (model, values): a repeated call gets the same
        read-only 0-d arrays (which the C pass packs once, :mod:`.c_kernels`)."""
        key = self.key(params, model)
        if key is not None:
            hit = self._memo.get(key)
            if hit is not None:
                return dict(hit)
        out = self.laid_out(n, params, model)
        if key is not None:
            frozen = {}
            for k, v in out.items():
                a = np.array(v, dtype=float)
                a.flags.writeable = False
                frozen[k] = a
            if len(self._memo) >= 64:
                self._memo.clear()
            self._memo[key] = frozen
            return dict(frozen)
        return out

    def key(self, params: dict, model):
        """A hashable key of (model, scalar values) for :meth:`resolve`; None when a value is
        an array (or anything but a plain number)."""
        items = []
        for k, v in params.items():
            if v is condense.EXACT:
                items.append((k, "exact"))
            elif type(v) in _NUMBERS or (type(v) is np.ndarray and v.ndim == 0 and v.dtype.kind in "fiu"):
                items.append((k, float(v)))
            else:
                return None
        try:
            return (model if isinstance(model, str) else tuple(self.model_effects(model)), tuple(sorted(items)))
        except TypeError:
            return None

    def resolve_in_full(self, n: int, params: dict, model) -> dict:
        """:meth:`resolve` without its memos: every name checked, every input placed, the
        defaults in use checked once, the description's and the legs' constraints checked."""
        scoped = self.scoped(params)
        effects = self.model_effects(model)
        on = {base_name(e) for e in effects}
        out = {}
        for name, p in self.parameters.items():
            if name in params:
                out[name] = self.array(name, params[name], n, params[name] is not condense.EXACT)
                continue
            # a default is checked once (where it is first used)
            check = (p.effect is None or p.effect in on) and name not in self._checked_defaults
            out[name] = self.default(name, p.default, n, check)
            if check:
                self._checked_defaults.add(name)
        for name, switch, effect, k in self.effect_switches(effects):
            out[name] = switch
            for q in effect.params if k else ():
                own = (q.name, k) in scoped
                value = self.array(f"{q.name}@{k}", scoped[(q.name, k)], n, True) if own else out[q.name]
                out[leg_input_name(q.name, k)] = value
        check_constraints(self.constraints, out, on)
        self.check_leg_constraints(out, effects, scoped)
        return out

    def laid_out(self, n: int, params: dict, model) -> dict:
        """:meth:`resolve_in_full` by a layout remembered per (model, names given): the
        defaults and switches placed once, each given value checked and placed at every input
        it feeds (a leg-level parameter's copies), the constraints checked on the result.
        The first call of a layout, or one whose layout cannot be remembered (an array
        default, an unhashable model), resolves in full."""
        try:
            key = (
                model if isinstance(model, str) else tuple(self.model_effects(model)),
                tuple(sorted((k, v is condense.EXACT) for k, v in params.items())),
            )
            layout = self._layouts.get(key)
        except TypeError:
            return self.resolve_in_full(n, params, model)
        if layout is None:
            out = self.resolve_in_full(n, params, model)  # checks the names and the defaults in use
            self._layouts.put(key, self.layout(params, model) or False)
            return out
        if layout is False:
            return self.resolve_in_full(n, params, model)
        template, given, live, on, effects, legs = layout
        out = dict(template)
        for key, name, targets, check in given:
            value = self.array(name, params[key], n, check)
            for target in targets:
                out[target] = value
        check_constraints(live, out, on)
        if legs:
            self.check_leg_constraints(out, effects, legs)
        return out

    def layout(self, params: dict, model):
        """``(template, given, live, on, effects, legs)`` of :meth:`laid_out`: the inputs in
        :meth:`resolve_in_full`'s order with the defaults and switches (None where a given
        value goes), each given name (as spelled, as shown) with the inputs it feeds and
        whether it is checked, the constraints that read a given value (the others hold: the
        first resolution checked them), the effects' base names, the effects and the legs
        with values of their own; None when a default is an array."""
        scoped = self.scoped(params)
        spelled = {split_scope(k, self.n_legs, "parameter"): k for k in params if k not in self.parameters}
        effects = self.model_effects(model)
        on = {base_name(e) for e in effects}
        template: dict = {}
        feeds: dict = {}  # given name (NAME@N: a leg's own value) -> the inputs it feeds
        for name, p in self.parameters.items():
            if name in params:
                template[name] = None
                feeds[name] = [name]
            elif isinstance(p.default, (float, int)):
                template[name] = self.default(name, p.default, 1, False)
            else:
                return None
        for name, switch, effect, k in self.effect_switches(effects):
            template[name] = switch
            for q in effect.params if k else ():
                target = leg_input_name(q.name, k)
                if (q.name, k) in scoped:
                    template[target] = None
                    feeds.setdefault(f"{q.name}@{k}", []).append(target)
                elif q.name in params:
                    template[target] = None
                    feeds[q.name].append(target)
                else:
                    template[target] = template[q.name]
        # the order of _resolve_params's checks: the parameters, then the legs' own values
        given = [
            (name, name, tuple(t), params[name] is not condense.EXACT) for name, t in feeds.items() if "@" not in name
        ]
        for name, t in feeds.items():
            if "@" in name:
                base, _, leg = name.partition("@")
                given.append((spelled[(base, int(leg))], name, tuple(t), True))
        fed = {target for _, _, targets, _ in given for target in targets}
        live = [c for c in self.constraints if fed.intersection(c.names)]
        return template, given, live, on, effects, {k: None for k in scoped}

    def effect_switches(self, effects):
        """``(input name, switch, effect, leg)`` of every effect's switch, in the inputs' order:
        a robot-level effect's one (``leg`` None), a leg-level effect's one per leg (``leg``
        1..n_legs); on where ``effects`` has the effect, or that leg's ``EFFECT@N``."""
        for e in self.effects:
            effect = self._effect[e]
            if not effect.leg_level:
                yield switch_name(e), _ON if e in effects else _OFF, effect, None
                continue
            for k in range(1, self.n_legs + 1):
                yield leg_switch_name(e, k), _ON if e in effects or f"{e}@{k}" in effects else _OFF, effect, k

    def default(self, name: str, value, n: int, check: bool) -> np.ndarray:
        """The default ``value`` of parameter ``name`` as a read-only 0-d array, the same
        object while the default stays the same (the C pass packs such scalars once,
        :mod:`.c_kernels`); checked where ``check``."""
        if check or not isinstance(value, (float, int)):  # an array default: as given
            return self.array(name, value, n, check)
        known = self._defaults.get(name)
        if known is None or known[0] != value:
            arr = np.array(value, dtype=float)
            arr.flags.writeable = False
            known = self._defaults[name] = (value, arr)
        return known[1]

    def check_leg_constraints(self, out: dict, effects, scoped: dict) -> None:
        """A leg's own values meet its effect's constraints (``r_i_l1@2 < r_o_l1@2``)."""
        for c in self.constraints:
            if c.effect is None or not self.robot.effect(c.effect).leg_level:
                continue
            for k in sorted({k for (_, k) in scoped}):
                if c.effect in effects or f"{c.effect}@{k}" in effects:
                    values = {n: out.get(leg_input_name(n, k), out.get(n)) for n in c.names}
                    try:
                        check_constraints([c], values, {c.effect})
                    except InputError as exc:
                        raise InputError(f"leg {k}: {exc}") from None

    def inputs(self, model, values: dict | None = None, **params) -> dict:
        """The generated code's input dict for ``model`` and parameter ``values`` (and keyword
        arguments): ``Evaluator.inputs``, which documents it. Scalars come back as floats,
        (N,) arrays as float arrays."""
        given = {**(values or {}), **params}
        sizes = [np.size(v) for v in given.values() if np.ndim(v) == 1]
        p = self.resolve(max(sizes, default=1), given, model)
        return {k: float(v) if np.ndim(v) == 0 else np.asarray(v, dtype=float) for k, v in p.items()}

    def stiffness_model(self, model) -> str:
        """``"flexible"`` (K_F, Eq. 13) when the model has a structural compliance, else
        ``"rigid"`` (K_R, Eq. 14)."""
        effects = self.model_effects(model)
        return self.remembered(
            ("stiffness_model", effects),
            lambda: "flexible" if any(self.robot.effect(base_name(e)).structural for e in effects) else "rigid",
        )

    def preloaded(self, effects) -> bool:
        """Whether the model's ``effects`` hold the gravity preload (an effect with the
        ``preload`` primitive: :mod:`.gravity`), remembered per model."""
        return self.remembered(
            ("preloaded", effects),
            lambda: any("preload" in self.robot.effect(base_name(e)).primitives for e in effects),
        )

    def remembered(self, key, compute):
        """``compute()``, remembered per (hashable) ``key`` of the model's effects."""
        try:
            return self._kinds[key]
        except (KeyError, TypeError):
            out = compute()
        try:
            self._kinds[key] = out
        except TypeError:  # effects given as an unhashable spec: computed every time
            pass
        return out
