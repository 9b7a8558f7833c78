/**
 * @class   vtkEchoregSequenceWriter
 * @brief   Writes an image of A-lines and its per-frame poses as a PLUS sequence file.
 *
 * The inverse of vtkEchoregSequenceReader, over echoreg::core::writeSequence: the input image (x
 * the sample, y the frame, one slice, one-component scalars of type unsigned char, signed char,
 * short, unsigned short or float) becomes frames of N x 1 samples; the field data
 * (echoreg::filters::SequenceFieldData: "Timestamp", per transform the 16-component matrices with
 * their status, the acquisition settings) becomes the per-frame timestamps and
 * `Seq_FrameNNNN_<Name>Transform` / `..TransformStatus` fields and echoreg's acquisition header
 * keys, as PLUS writes them (Lasso et al. 2014). An image without samples (a tracker-only capture)
 * is written as DimSize = 0 0 F with its poses.
 *
 * Format: from the file name (.nrrd: NRRD; .mha/.mhd: MetaImage), compressed (zlib / gzip) unless
 * CompressOff(). The file is written under a temporary name and renamed, so a failure leaves no
 * partial output. Errors (no file name, an unwritable folder, an input of several slices or
 * components, an element type PLUS cannot store, frames in the field data that do not match the
 * image) are reported with vtkErrorMacro, GetLastError() and the error code; Write() returns 0.
 *
 * Input (port 0): vtkImageData as vtkEchoregSequenceReader makes it.
 * Defaults: no file name, compression on.
 */
#pragma once

#include <vtkWriter.h>

#include <string>

class vtkEchoregSequenceWriter : public vtkWriter {
 public:
  static vtkEchoregSequenceWriter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregSequenceWriter, vtkWriter)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  ///@{
  /**
   * Path of the sequence to write (.igs.mha, .mha, .mhd, .igs.nrrd, .nrrd). Default: empty.
   */
  void SetFileName(const std::string& fileName);
  const std::string& GetFileName() const { return this->FileName; }
  ///@}

  ///@{
  /**
   * Compress the pixel data (zlib for MetaImage, gzip for NRRD). Default on.
   */
  void SetCompress(bool compress);
  bool GetCompress() const { return this->Compress; }
  void CompressOn() { this->SetCompress(true); }
  void CompressOff() { this->SetCompress(false); }
  ///@}

  /**
   * Message of the last failure, empty after a success.
   */
  const std::string& GetLastError() const { return this->LastError; }

  /**
   * Number of times the file was written.
   */
  int GetExecutionCount() const { return this->ExecutionCount; }

 protected:
  vtkEchoregSequenceWriter();
  ~vtkEchoregSequenceWriter() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  void WriteData() override;

 private:
  vtkEchoregSequenceWriter(const vtkEchoregSequenceWriter&) = delete;
  void operator=(const vtkEchoregSequenceWriter&) = delete;

  void Fail(const std::string& message);

  std::string FileName;
  bool Compress = true;
  std::string LastError;
  int ExecutionCount = 0;
};
