"""[[material]] tables -> schema.Material: library merge, elastic constants, models, failure."""

from __future__ import annotations

import math

from impactsim.case.errors import KeyPath, suggest
from impactsim.case.read import Reader, in_range, non_negative, positive, type_name
from impactsim.case.schema import EOS, Failure, Material, Strength
from impactsim.case.spec import ELASTIC_CONSTANTS, EOS_KEYS, MATERIAL, STRENGTH_KEYS
from impactsim.materials import library
from impactsim.materials.params import longitudinal_wave_speed


def library_names() -> list[str]:
    """Entry names and aliases, for suggestions."""
    return library.names() + list(library.aliases())


def merge_library(raw: dict, path: KeyPath) -> tuple[dict, list[str]]:
    """The material table over its library entry, and the keys the case changed.

    Keys given in the case replace the entry's; elastic constants as a set (giving any drops all
    of the entry's); strength and eos tables key by key unless the case changes the model, in
    which case the case's table replaces the entry's; failure key by key (a failure key set to
    "none" switches off that mechanism of the entry).
    """
    name = raw["library"]
    if not isinstance(name, str):
        raise path.key("library").error(f"expected a string, got {type_name(name)}")
    canon = library.canonical(name)
    if canon is None:
        raise path.key("library").error(
            f"unknown library material '{name}'{suggest(name, library_names())}")
    merged = library.get(canon)
    if any(k in raw for k in ELASTIC_CONSTANTS):
        for k in ELASTIC_CONSTANTS:
            merged.pop(k, None)
    changed = []
    for key, value in raw.items():
        if key in ("library", "name", "source"):
            continue
        old = merged.get(key)
        if key in ("strength", "eos", "failure") and isinstance(value, dict) \
                and isinstance(old, dict):
            same_model = "model" not in value or value["model"] == old.get("model")
            merged[key] = {**old, **value} if same_model or key == "failure" else dict(value)
            if key == "failure":  # "none" drops a mechanism the entry brings
                merged[key] = {k: v for k, v in merged[key].items() if v != "none"}
            changed += [f"{key}.{k}" for k in value]
        else:
            merged[key] = value
            changed.append(key)
    merged["name"] = raw.get("name", canon)
    if "source" in raw:
        merged["source"] = raw["source"]
    elif changed:
        merged["source"] = f"{merged.get('source', '')} [changed in the case: {', '.join(changed)}]"
    return merged, changed


def read_material(raw: dict, path: KeyPath) -> Material:
    """One [[material]] table (merged with its library entry if it names one)."""
    hint = raw.get("name", raw.get("library"))
    if isinstance(hint, str) and hint:
        path = path.labelled(f'material "{hint}"')
    if "library" in raw:
        Reader(raw, MATERIAL, path)  # names the case's own unknown keys before merging
        raw, _ = merge_library(raw, path)
    r = Reader(raw, MATERIAL, path)
    if "name" not in raw:
        raise r.error("name", "missing required key 'name' (or give `library`)")
    name = r.get("name")
    if not name:
        raise r.error("name", "must not be empty")
    r = Reader(raw, MATERIAL, path.labelled(f'material "{name}"'))
    density = positive(r.get("density"), r.at("density"))
    eos = _eos(r)
    shear, bulk = _elastic(r, density, eos)
    mat = Material(
        name=name,
        density=density,
        shear_modulus=shear,
        bulk_modulus=bulk,
        specific_heat=positive(r.get("specific_heat"), r.at("specific_heat")),
        taylor_quinney=in_range(r.get("taylor_quinney"), r.at("taylor_quinney"), 0.0, 1.0,
                                lo_open=False, hi_open=False),
        initial_temperature=positive(r.get("initial_temperature"), r.at("initial_temperature")),
        strength=_strength(r),
        eos=eos,
        failure=_failure(r),
        source=r.get("source"),
    )
    wave = longitudinal_wave_speed(mat)
    if not 0.0 < wave < math.inf:  # a density off by hundreds of decades (units)
        raise r.error("density", f"{density:g} kg/m^3 with these elastic constants (or eos.c0) "
                                 f"gives a wave speed of {wave:g} m/s: no time step can be "
                                 "taken")
    return mat


def library_material(name: str) -> Material:
    """A library entry as a Material, named by its entry name."""
    canon = library.canonical(name)
    assert canon is not None
    return read_material({"library": canon}, KeyPath(("material",), f'library "{canon}"'))


def _elastic(r: Reader, density: float, eos: EOS) -> tuple[float, float]:
    """(G, K) from any two elastic constants, or from G and eos.c0 (K = rho c0^2)."""
    given = r.given(ELASTIC_CONSTANTS)
    two = "give two of youngs_modulus, poisson_ratio, shear_modulus, bulk_modulus " \
          "(or shear_modulus with eos.c0)"
    if len(given) > 2:
        raise r.error(given[2], f"too many elastic constants ({', '.join(given)}): {two}")
    values = {}
    for k in given:
        v = r.get(k)
        if k == "poisson_ratio":
            in_range(v, r.at(k), -1.0, 0.5)
        else:
            positive(v, r.at(k))
        values[k] = v
    if len(given) == 1 and given[0] == "shear_modulus" and eos.c0 > 0.0:
        return values["shear_modulus"], density * eos.c0 * eos.c0  # inf, not OverflowError
    if len(given) < 2:
        where = given[0] if given else "shear_modulus"
        raise r.error(where, f"missing elastic constants: {two}")
    nu = _poisson(values)
    if "poisson_ratio" not in values and not -1.0 < nu < 0.5:
        raise r.error(given[1], f"{given[0]} and {given[1]} give a Poisson ratio of {nu:.4g}, "
                                "outside (-1, 0.5): not a stable isotropic material")
    E, G, K = values.get("youngs_modulus"), values.get("shear_modulus"), values.get("bulk_modulus")
    if G is None:
        G = E / (2 * (1 + nu)) if E is not None else 3 * K * (1 - 2 * nu) / (2 * (1 + nu))
    if K is None:
        K = E / (3 * (1 - 2 * nu)) if E is not None else 2 * G * (1 + nu) / (3 * (1 - 2 * nu))
    return G, K


def _poisson(v: dict[str, float]) -> float:
    if "poisson_ratio" in v:
        return v["poisson_ratio"]
    E, G, K = v.get("youngs_modulus"), v.get("shear_modulus"), v.get("bulk_modulus")
    if E is not None and G is not None:
        return E / (2 * G) - 1
    if E is not None and K is not None:
        return (3 * K - E) / (6 * K)
    return (3 * K - 2 * G) / (2 * (3 * K + G))


def _only_model_keys(r: Reader, model: str, allowed: tuple[str, ...], what: str) -> None:
    for key in r.raw:
        if key != "model" and key not in allowed:
            theirs = ", ".join(allowed) if allowed else "none besides model"
            raise r.error(key, f"key '{key}' does not apply to {what} model '{model}' "
                               f"(its keys: {theirs})")


def _strength(mat: Reader) -> Strength:
    r = mat.sub("strength")
    model = r.get("model")
    _only_model_keys(r, model, STRENGTH_KEYS[model], "strength")
    if model == "elastic":
        return Strength(model=model)
    if model == "ideal-plastic":
        y = positive(r.require("yield_stress", " for strength model 'ideal-plastic'"),
                     r.at("yield_stress"))
        return Strength(model=model, yield_stress=y)
    why = " for strength model 'johnson-cook'"
    s = Strength(
        model=model,
        A=positive(r.require("A", why), r.at("A")),
        B=non_negative(r.require("B", why), r.at("B")),
        n=non_negative(r.get("n"), r.at("n")),
        C=non_negative(r.get("C"), r.at("C")),
        m=positive(r.get("m"), r.at("m")),
        strain_rate_ref=positive(r.get("strain_rate_ref"), r.at("strain_rate_ref")),
        room_temperature=positive(r.get("room_temperature"), r.at("room_temperature")),
        melt_temperature=r.get("melt_temperature"),
    )
    if not s.melt_temperature > s.room_temperature:
        raise r.error("melt_temperature", f"must be above room_temperature ("
                      f"{s.room_temperature:g} K), got {s.melt_temperature:g} K")
    return s


def _eos(mat: Reader) -> EOS:
    r = mat.sub("eos")
    model = r.get("model")
    _only_model_keys(r, model, EOS_KEYS[model], "eos")
    if model == "linear":
        c0 = r.get("c0")
        if r.has("c0"):
            positive(c0, r.at("c0"))
        return EOS(model=model, c0=c0)
    why = " for eos model 'mie-gruneisen'"
    return EOS(
        model=model,
        c0=positive(r.require("c0", why), r.at("c0")),
        s=non_negative(r.require("s", why), r.at("s")),
        gamma0=non_negative(r.require("gamma0", why), r.at("gamma0")),
    )


def _failure(mat: Reader) -> Failure:
    r = mat.sub("failure")
    if r == "none":
        return Failure()
    f = Failure()
    if r.has("spall_strength"):
        f.spall_strength = positive(r.get("spall_strength"), r.at("spall_strength"))
    if r.has("spall_time"):
        # inert without spall_strength (a case may switch a library entry's spall off)
        f.spall_time = positive(r.get("spall_time"), r.at("spall_time"))
    if r.has("loosening"):
        f.loosening = in_range(r.get("loosening"), r.at("loosening"), 0.0, 1.0)
        if f.spall_strength is None:
            raise r.error("loosening", "loosening acts on spalled cells: it needs spall_strength")
    if r.has("jc_damage"):
        f.jc_damage = r.get("jc_damage")
    if r.has("erosion"):
        f.erosion = r.get("erosion")
        if f.erosion == "fractured":
            if r.has("erosion_value"):
                raise r.error("erosion_value", "erosion 'fractured' takes no erosion_value")
        elif r.has("erosion_value"):
            f.erosion_value = positive(r.get("erosion_value"), r.at("erosion_value"))
        elif f.erosion == "jc-damage":
            f.erosion_value = 1.0
        else:
            raise r.error("erosion_value", f"missing required key 'erosion_value' for erosion "
                                           f"'{f.erosion}'")
        if f.erosion == "jc-damage" and f.jc_damage is None:
            raise r.error("jc_damage", "missing required key 'jc_damage' (D1..D5) for erosion "
                                       "'jc-damage'")
        if f.erosion == "fractured" and f.loosening is None:
            raise r.error("erosion", "erosion 'fractured' removes fully fractured cells: it "
                                     "needs spall_strength and loosening")
    elif r.has("erosion_value"):
        raise r.error("erosion_value", "erosion_value needs an erosion criterion (erosion = ...)")
    if r.has("fracture_strain"):
        f.fracture_strain = positive(r.get("fracture_strain"), r.at("fracture_strain"))
    return f


__all__ = ["read_material", "library_material", "library_names", "merge_library"]
