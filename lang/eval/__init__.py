"""The evaluator: scene syntax (lang.syntax) to the IR (lang.ir). lang.evaluate is the front
door; lang.eval.interpreter runs directives, macros and includes; the builder modules turn
blocks into values through the build context (lang.eval.context)."""
