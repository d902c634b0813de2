// Every reconstruction model, one line each: the name --model and
// ReconstructionOptions.model take, and the function in the model's folder
// beside this file that makes it. Adding a model is its folder and a line
// here. Names only where the header is read without the engine (the
// server checks a request's model without linking it):
//
//   #define NAME(name, make) name,
//   const char* names[] = {PF_RECON_MODELS(NAME)};
#ifndef POINTFORWARD_ENGINE_RECON_MODELS_MODEL_LIST_H_
#define POINTFORWARD_ENGINE_RECON_MODELS_MODEL_LIST_H_

#define PF_RECON_MODELS(MODEL)         \
  MODEL("analytic", MakeAnalyticModel) \
  MODEL("pixel-aligned", MakePixelAlignedModel)

#endif  // POINTFORWARD_ENGINE_RECON_MODELS_MODEL_LIST_H_
