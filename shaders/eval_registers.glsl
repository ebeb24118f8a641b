// The stackless evaluator's register file as scalar variables (R##0 .. R##31) instead of a
// dynamically indexed array: llvmpipe (and many GPU compilers) turn a dynamically indexed local
// array into per-lane scratch memory, while a chain of selects keeps every register in SSA
// values. FIELD_REGS (specialization constant 2, Program::fieldRegisters) folds away the
// registers a program does not use, so a typical 2-8 register program costs 2-8 selects per
// access. Statement macros: REG_DECL(T, R, zero), REG_READ(out, R, index), REG_WRITE(R, index, v).
#ifndef BLOBVK_EVAL_REGISTERS_GLSL
#define BLOBVK_EVAL_REGISTERS_GLSL

#define REG_DECL(T, R, Z) \
  T R##0 = Z; T R##1 = Z; T R##2 = Z; T R##3 = Z; T R##4 = Z; T R##5 = Z; T R##6 = Z; T R##7 = Z; T R##8 = Z; T R##9 = Z; T R##10 = Z; T R##11 = Z; T R##12 = Z; T R##13 = Z; T R##14 = Z; T R##15 = Z; T R##16 = Z; T R##17 = Z; T R##18 = Z; T R##19 = Z; T R##20 = Z; T R##21 = Z; T R##22 = Z; T R##23 = Z; T R##24 = Z; T R##25 = Z; T R##26 = Z; T R##27 = Z; T R##28 = Z; T R##29 = Z; T R##30 = Z; T R##31 = Z;

#define REG_READ(OUT, R, I) \
  OUT = R##0; \
  if (FIELD_REGS > 1u) OUT = (I) == 1u ? R##1 : OUT; \
  if (FIELD_REGS > 2u) OUT = (I) == 2u ? R##2 : OUT; \
  if (FIELD_REGS > 3u) OUT = (I) == 3u ? R##3 : OUT; \
  if (FIELD_REGS > 4u) OUT = (I) == 4u ? R##4 : OUT; \
  if (FIELD_REGS > 5u) OUT = (I) == 5u ? R##5 : OUT; \
  if (FIELD_REGS > 6u) OUT = (I) == 6u ? R##6 : OUT; \
  if (FIELD_REGS > 7u) OUT = (I) == 7u ? R##7 : OUT; \
  if (FIELD_REGS > 8u) OUT = (I) == 8u ? R##8 : OUT; \
  if (FIELD_REGS > 9u) OUT = (I) == 9u ? R##9 : OUT; \
  if (FIELD_REGS > 10u) OUT = (I) == 10u ? R##10 : OUT; \
  if (FIELD_REGS > 11u) OUT = (I) == 11u ? R##11 : OUT; \
  if (FIELD_REGS > 12u) OUT = (I) == 12u ? R##12 : OUT; \
  if (FIELD_REGS > 13u) OUT = (I) == 13u ? R##13 : OUT; \
  if (FIELD_REGS > 14u) OUT = (I) == 14u ? R##14 : OUT; \
  if (FIELD_REGS > 15u) OUT = (I) == 15u ? R##15 : OUT; \
  if (FIELD_REGS > 16u) OUT = (I) == 16u ? R##16 : OUT; \
  if (FIELD_REGS > 17u) OUT = (I) == 17u ? R##17 : OUT; \
  if (FIELD_REGS > 18u) OUT = (I) == 18u ? R##18 : OUT; \
  if (FIELD_REGS > 19u) OUT = (I) == 19u ? R##19 : OUT; \
  if (FIELD_REGS > 20u) OUT = (I) == 20u ? R##20 : OUT; \
  if (FIELD_REGS > 21u) OUT = (I) == 21u ? R##21 : OUT; \
  if (FIELD_REGS > 22u) OUT = (I) == 22u ? R##22 : OUT; \
  if (FIELD_REGS > 23u) OUT = (I) == 23u ? R##23 : OUT; \
  if (FIELD_REGS > 24u) OUT = (I) == 24u ? R##24 : OUT; \
  if (FIELD_REGS > 25u) OUT = (I) == 25u ? R##25 : OUT; \
  if (FIELD_REGS > 26u) OUT = (I) == 26u ? R##26 : OUT; \
  if (FIELD_REGS > 27u) OUT = (I) == 27u ? R##27 : OUT; \
  if (FIELD_REGS > 28u) OUT = (I) == 28u ? R##28 : OUT; \
  if (FIELD_REGS > 29u) OUT = (I) == 29u ? R##29 : OUT; \
  if (FIELD_REGS > 30u) OUT = (I) == 30u ? R##30 : OUT; \
  if (FIELD_REGS > 31u) OUT = (I) == 31u ? R##31 : OUT;

#define REG_WRITE(R, I, V) \
  R##0 = (I) == 0u ? (V) : R##0; \
  if (FIELD_REGS > 1u) R##1 = (I) == 1u ? (V) : R##1; \
  if (FIELD_REGS > 2u) R##2 = (I) == 2u ? (V) : R##2; \
  if (FIELD_REGS > 3u) R##3 = (I) == 3u ? (V) : R##3; \
  if (FIELD_REGS > 4u) R##4 = (I) == 4u ? (V) : R##4; \
  if (FIELD_REGS > 5u) R##5 = (I) == 5u ? (V) : R##5; \
  if (FIELD_REGS > 6u) R##6 = (I) == 6u ? (V) : R##6; \
  if (FIELD_REGS > 7u) R##7 = (I) == 7u ? (V) : R##7; \
  if (FIELD_REGS > 8u) R##8 = (I) == 8u ? (V) : R##8; \
  if (FIELD_REGS > 9u) R##9 = (I) == 9u ? (V) : R##9; \
  if (FIELD_REGS > 10u) R##10 = (I) == 10u ? (V) : R##10; \
  if (FIELD_REGS > 11u) R##11 = (I) == 11u ? (V) : R##11; \
  if (FIELD_REGS > 12u) R##12 = (I) == 12u ? (V) : R##12; \
  if (FIELD_REGS > 13u) R##13 = (I) == 13u ? (V) : R##13; \
  if (FIELD_REGS > 14u) R##14 = (I) == 14u ? (V) : R##14; \
  if (FIELD_REGS > 15u) R##15 = (I) == 15u ? (V) : R##15; \
  if (FIELD_REGS > 16u) R##16 = (I) == 16u ? (V) : R##16; \
  if (FIELD_REGS > 17u) R##17 = (I) == 17u ? (V) : R##17; \
  if (FIELD_REGS > 18u) R##18 = (I) == 18u ? (V) : R##18; \
  if (FIELD_REGS > 19u) R##19 = (I) == 19u ? (V) : R##19; \
  if (FIELD_REGS > 20u) R##20 = (I) == 20u ? (V) : R##20; \
  if (FIELD_REGS > 21u) R##21 = (I) == 21u ? (V) : R##21; \
  if (FIELD_REGS > 22u) R##22 = (I) == 22u ? (V) : R##22; \
  if (FIELD_REGS > 23u) R##23 = (I) == 23u ? (V) : R##23; \
  if (FIELD_REGS > 24u) R##24 = (I) == 24u ? (V) : R##24; \
  if (FIELD_REGS > 25u) R##25 = (I) == 25u ? (V) : R##25; \
  if (FIELD_REGS > 26u) R##26 = (I) == 26u ? (V) : R##26; \
  if (FIELD_REGS > 27u) R##27 = (I) == 27u ? (V) : R##27; \
  if (FIELD_REGS > 28u) R##28 = (I) == 28u ? (V) : R##28; \
  if (FIELD_REGS > 29u) R##29 = (I) == 29u ? (V) : R##29; \
  if (FIELD_REGS > 30u) R##30 = (I) == 30u ? (V) : R##30; \
  if (FIELD_REGS > 31u) R##31 = (I) == 31u ? (V) : R##31;

#endif  // BLOBVK_EVAL_REGISTERS_GLSL
