// The statements of primitiveGradientOf (eval_gradient_formulas.glsl): the field of a primitive
// of `type` at p in its local frame, its gradient in `grad`; p0, p1, p2 its record's skeleton
// words. No include guard: it is included as the body of a function, once by
// eval_gradient_formulas.glsl (`type` a parameter, for the interpreter) and once per primitive
// type by the generated gradient (vk/eval/gradient_codegen.cpp, `type` a constant). With a
// constant type the other types' branches are gone before the driver sees the code: lavapipe's
// NIR passes then work on one formula per primitive instead of every type's at each of the
// program's primitives, a large part of the vertex kernel's build. The float operations are the
// same text either way, so the values are bit for bit equal.
  precise vec3 d = p - p0.xyz;
  precise float dd = 1.0;  // no field for an unknown type
  precise vec3 dg = vec3(0.0);
  precise vec3 g_;
  precise float field;
  if (GRADIENT_FORMULA_HAS_PRIM(PRIM_POINT) && type == PRIM_POINT) {
    dd = dot3(d, d);
    dg = d * 2.0;
  } else if (GRADIENT_FORMULA_HAS_PRIM(PRIM_LINE) && type == PRIM_LINE) {
    float t = clamp(dot3(d, p1.xyz) * p1.w, 0.0, 1.0);
    vec3 e = d - p1.xyz * t;
    dd = dot3(e, e);
    dg = e * 2.0;
  } else if ((GRADIENT_FORMULA_HAS_PRIM(PRIM_CYLINDER) && type == PRIM_CYLINDER) ||
             (GRADIENT_FORMULA_HAS_PRIM(PRIM_DISC) && type == PRIM_DISC) ||
             (GRADIENT_FORMULA_HAS_PRIM(PRIM_RING) && type == PRIM_RING)) {
    vec3 n = p1.xyz;
    float y = dot3(d, n);
    float r2 = max(dot3(d, d) - y * y, 0.0);
    float rl = sqrt(r2);
    if (GRADIENT_FORMULA_HAS_PRIM(PRIM_CYLINDER) && type == PRIM_CYLINDER) {
      float x = max(rl - p2.x, 0.0);
      float below = -y, above = y - p2.y;
      float h = max(max(below, above), 0.0);
      dd = x * x + h * h;
      float cx = x > 0.0 ? 2.0 * x / rl : 0.0;
      float ch = h > 0.0 ? (below < above ? 2.0 * h : -2.0 * h) : 0.0;
      dg = (d - n * y) * cx + n * ch;
    } else {
      float radial = type == PRIM_DISC ? max(rl - p2.x, 0.0) : rl - p2.x;
      dd = radial * radial + y * y;
      bool radialGradient = type == PRIM_DISC ? radial > 0.0 : rl > 0.0;
      float cr = radialGradient ? 2.0 * radial / rl : 0.0;
      dg = (d - n * y) * cr + n * (2.0 * y);
    }
  } else if (GRADIENT_FORMULA_HAS_PRIM(PRIM_CUBE) && type == PRIM_CUBE) {
    vec3 e = max(abs(d) - p1.xyz, vec3(0.0));
    dd = dot3(e, e);
    dg = vec3(d.x < 0.0 ? -2.0 * e.x : 2.0 * e.x, d.y < 0.0 ? -2.0 * e.y : 2.0 * e.y,
              d.z < 0.0 ? -2.0 * e.z : 2.0 * e.z);
  } else if (GRADIENT_FORMULA_HAS_PRIM(PRIM_TRIANGLE) && type == PRIM_TRIANGLE) {
    vec3 e = p - triangleClosest(p, p0.xyz, p1.xyz, p2.xyz);
    dd = dot3(e, e);
    dg = e * 2.0;
  } else if (GRADIENT_FORMULA_HAS_PRIM(PRIM_QUADRIC) && type == PRIM_QUADRIC) {
    dd = dot3(d, d);
    float t = 1.0 - dd;
    bool inside = dd < 1.0;
    g_ = inside ? d * (2.0 * (-2.0 * p0.w * t)) : vec3(0.0);  // S t^2: -2 S t
    grad = g_;
    field = inside ? p0.w * t * t : 0.0;
    return field;
  }
  float t = 1.0 - dd;
  bool inside = dd < 1.0;
  g_ = inside ? dg * (-3.0 * t * t) : vec3(0.0);
  grad = g_;
  field = inside ? t * t * t : 0.0;
  return field;
